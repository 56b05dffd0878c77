"""One websocket message never takes the GUI down: raw clients send the edits a page never would,
and every other page stays open, nothing is applied or kept in viser's state, and later pages still
load."""

import logging
import math
import time

import msgspec
import pytest
from viser import _messages
from websockets.sync.client import connect

from judo.runtime.app import App
from tests.runtime.test_gui_access import PROTOCOL

CAMERA = _messages.ViewerCameraMessage(
    wxyz=(1.0, 0.0, 0.0, 0.0),
    position=(0.0, -3.0, 1.0),
    fov=1.0,
    near=0.01,
    far=100.0,
    image_height=480,
    image_width=640,
    look_at=(0.0, 0.0, 0.0),
    up_direction=(0.0, 0.0, 1.0),
)


@pytest.fixture
def app(port, wait_until):
    app = App("cartpole", "ps", port=port, seed=0, num_workers=1)
    app.start()
    wait_until(lambda: app.gui.shown_generation == app.session.generation, what="the GUI to build")
    yield app
    app.stop()


def page(port: int, register: bool = True):
    """A raw client as a page opens it: same origin, and registered by its first camera message."""
    websocket = connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=[PROTOCOL],  # type: ignore[list-item]
        origin=f"http://127.0.0.1:{port}",  # type: ignore[arg-type]
        open_timeout=10,
        max_queue=None,  # frames left unread must not hold up the closing handshake
        close_timeout=2,
    )
    if register:
        websocket.send(msgspec.msgpack.encode(CAMERA.as_serializable_dict()))
    return websocket


def edit(websocket, handle, updates: dict) -> None:
    """Send `updates` for widget `handle` as a page's GuiUpdateMessage, whatever their values."""
    websocket.send(
        msgspec.msgpack.encode(
            {"type": "GuiUpdateMessage", "uuid": handle._impl.uuid, "updates": updates}
        )
    )


def frames_for(websocket, seconds: float) -> int:
    """How many frames arrive in `seconds`; raises ConnectionClosed if the server closes the
    page."""
    count, end = 0, time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        try:
            websocket.recv(timeout=left)
            count += 1
        except TimeoutError:
            break
    return count


def saved(app: App) -> list:
    """The widget edits held in viser's saved state, which every later page is sent."""
    buffer = app.gui.server._websock_server._broadcast_buffer.message_from_id.values()
    return [m for m in buffer if isinstance(m, _messages.GuiUpdateMessage)]


def poison(app: App) -> list[tuple[object, dict]]:
    """(widget handle, updates) pairs no page sends: each would break, or lie on, every page."""
    (num_rollouts,) = app.gui.panels["optimizer"].handles("num_rollouts")
    (horizon,) = app.gui.panels["controller"].handles("horizon")
    (spline_order,) = app.gui.panels["controller"].handles("spline_order")
    (noise_ramp,) = app.gui.panels["optimizer"].handles("use_noise_ramp")
    return [
        # viser casts to int(1e20), which msgpack cannot send: 1011 for all
        (num_rollouts, {"value": 1e20}),
        (num_rollouts, {"value": 2**63}),
        (horizon, {"value": math.nan}),
        (horizon, {"value": "abc"}),
        (spline_order, {"value": "quintic"}),
        (noise_ramp, {"value": "yes"}),
        (num_rollouts, {"min": -(2**63)}),  # a page only ever sets value
        (num_rollouts, {"value": 20, "max": 1e20}),
    ]


def test_a_poison_edit_closes_no_page_and_is_neither_applied_nor_kept(app, caplog):
    port, configs = app.port, app.configs()
    before = [(handle, handle.value) for handle, _ in poison(app)]
    with (
        caplog.at_level(logging.WARNING, logger="judo.gui"),
        page(port) as first,
        page(port) as second,
    ):
        assert frames_for(first, 1.0) > 0 and frames_for(second, 1.0) > 0
        with page(port, register=False) as stranger, page(port) as sender:
            frames_for(sender, 0.5)
            # alone first: unguarded, viser closes every page with 1011
            edit(stranger, *poison(app)[0])
            assert frames_for(first, 1.5) > 0 and frames_for(second, 0.5) > 0
            for handle, updates in poison(app):
                edit(stranger, handle, updates)
                edit(sender, handle, updates)
            # unregistered
            edit(stranger, app.gui.panels["optimizer"].handles("num_rollouts")[0], {"value": 20})
            assert frames_for(sender, 1.0) > 0  # its page is sent the values in force again
        for websocket in (first, second):  # both still served after the poison
            assert frames_for(websocket, 1.5) > 0
        with page(port) as later:  # a page opened afterwards loads
            assert frames_for(later, 1.5) > 0
    assert [(handle, handle.value) for handle, _ in poison(app)] == before
    assert app.configs() == configs
    assert not [m for m in saved(app) if m.uuid in {h._impl.uuid for h, _ in before}]
    assert "widget edit refused" in caplog.text and "has not registered" in caplog.text


def test_an_ordinary_edit_from_a_registered_page_is_still_applied(app, wait_until):
    (num_rollouts,) = app.gui.panels["optimizer"].handles("num_rollouts")
    with page(app.port) as sender:
        frames_for(sender, 0.5)
        edit(sender, num_rollouts, {"value": 24.0})  # a browser sends every number as a float
        wait_until(
            lambda: app.configs()["optimizer"].num_rollouts == 24,
            timeout=10,
            what="num_rollouts = 24",
        )
