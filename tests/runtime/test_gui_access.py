"""Who may drive the GUI: same-origin websockets only, a token for remote use, no share tunnel
unless asked for, and a loopback address by default."""

import logging
import socket
import urllib.error
import urllib.request

import pytest
import viser
from websockets.datastructures import Headers
from websockets.exceptions import InvalidStatus
from websockets.http11 import Request
from websockets.sync.client import connect

from judo.core.errors import ConfigError, GuiStartError
from judo.runtime import launch
from judo.runtime.address import check_host, check_port, check_token, is_loopback
from judo.runtime.app import App
from judo.runtime.gui.access import AccessPolicy

PROTOCOL = f"viser-v{viser.__version__}"


def open_websocket(port: int, path: str = "", origin: str | None = None, host: str = "127.0.0.1"):
    """A raw websocket client as a page at `origin` (None: a non-browser client) would open it."""
    return connect(
        f"ws://{host}:{port}{path}",  # the Host header; the socket always goes to 127.0.0.1
        sock=socket.create_connection(("127.0.0.1", port), timeout=10),
        subprotocols=[PROTOCOL],  # type: ignore[list-item]
        origin=origin,  # type: ignore[arg-type]
        open_timeout=10,
    )


def refused(port: int, **kwargs) -> int:
    """The HTTP status the handshake was refused with (fails if it was accepted)."""
    with pytest.raises(InvalidStatus) as refusal:
        open_websocket(port, **kwargs).close()
    return refusal.value.response.status_code


@pytest.fixture
def app(port):
    app = App("cartpole", "ps", port=port, seed=0, num_workers=1)
    app.start()
    yield app
    app.stop()


def test_the_gui_listens_on_loopback_by_default(app):
    assert app.host == "127.0.0.1" and app.token is None
    assert app.gui.server.get_host() == "127.0.0.1"
    assert launch.RunOptions().host == "127.0.0.1"


def test_a_cross_origin_websocket_is_refused_and_a_same_origin_one_accepted(app, caplog):
    port = app.port
    with caplog.at_level(logging.WARNING, logger="judo.gui"):
        assert refused(port, origin="http://evil.example") == 403
    assert "cross-origin websocket refused: Origin 'http://evil.example'" in caplog.text
    assert refused(port, origin=f"http://localhost:{port + 1}") == 403  # another local app's page
    with open_websocket(port, origin=f"http://127.0.0.1:{port}") as websocket:
        assert websocket.recv(timeout=10)  # the GUI's state arrives
    with open_websocket(port) as websocket:  # no Origin: a local program, not a page in a browser
        assert websocket.recv(timeout=10)


def test_a_dns_rebinding_page_is_refused(app):
    # evil.example resolving to 127.0.0.1: same "origin" as far as the browser knows
    port = app.port
    assert refused(port, origin=f"http://evil.example:{port}", host="evil.example") == 403


def test_a_refused_client_cannot_change_anything(app, wait_until):
    horizon = app.configs()["controller"].horizon
    refused(app.port, origin="http://evil.example")
    assert app.configs()["controller"].horizon == horizon and app.gui.server.get_clients() == {}


def test_a_token_is_required_in_the_path_of_page_and_websocket(port):
    app = App("cartpole", "ps", port=port, token="s3cret-token", num_workers=1)
    app.start()
    try:
        assert app.gui.url == f"http://127.0.0.1:{port}/s3cret-token"
        assert refused(port, origin=f"http://127.0.0.1:{port}") == 403
        assert refused(port, path="/wrong-token", origin=f"http://127.0.0.1:{port}") == 403
        assert refused(port, path="/s3cret-token", origin="http://evil.example") == 403
        with open_websocket(
            port, path="/s3cret-token", origin=f"http://127.0.0.1:{port}"
        ) as websocket:
            assert websocket.recv(timeout=10)
        with pytest.raises(urllib.error.HTTPError) as page:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10)
        assert page.value.code == 403 and b"needs its access token" in page.value.read()
        with urllib.request.urlopen(app.gui.url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read(2000).lower()
    finally:
        app.stop()


def test_a_gui_beyond_loopback_gets_a_token_and_a_warning(port, caplog):
    app = App("cartpole", "ps", host="0.0.0.0", port=port, num_workers=1)
    assert app.token is not None and len(app.token) >= 20
    with caplog.at_level(logging.WARNING, logger="judo.app"):
        app.start()
    try:
        assert app.gui.url == f"http://localhost:{port}/{app.token}"
        warning = "the GUI listens on 0.0.0.0 (every network interface): anyone who can reach port"
        assert warning in caplog.text and "SSH tunnel" in caplog.text
        assert refused(port) == 403  # even a local program needs the token now
    finally:
        app.stop()


def test_the_share_button_is_hidden_and_share_requests_refused_unless_asked_for(app, caplog):
    from viser import _messages

    server = app.gui.server
    theme = [
        m
        for m in server._websock_server._broadcast_buffer.message_from_id.values()
        if type(m).__name__ == "ThemeConfigurationMessage"
    ]
    assert theme and not theme[-1].show_share_button
    with caplog.at_level(logging.WARNING, logger="judo.gui"):
        for handler in server._websock_server._incoming_handlers[_messages.ShareUrlRequest]:
            handler(0, _messages.ShareUrlRequest())
    assert (
        "asked for a public share URL; refused (start the app with --share to allow it)"
        in caplog.text
    )
    assert server._share_tunnel is None


def test_share_shows_the_button(port):
    app = App("cartpole", "ps", port=port, share=True, num_workers=1)
    app.start()
    try:
        buffer = app.gui.server._websock_server._broadcast_buffer.message_from_id.values()
        theme = [m for m in buffer if type(m).__name__ == "ThemeConfigurationMessage"]
        assert theme[-1].show_share_button
    finally:
        app.stop()


@pytest.mark.parametrize("port", [-1, 65536, 99999, 8080.5, "8080", True])
def test_a_port_out_of_range_is_refused_at_the_boundary(port):
    with pytest.raises(
        ConfigError,
        match=r"port must be an integer in 0\.\.65535 "
        r"\(0 picks a free port\), got ",
    ):
        check_port(port)
    with pytest.raises(ConfigError):
        App("cartpole", "ps", port=port)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("host", "message"),
    [
        ("999.1.1.1", "cannot listen on '999.1.1.1': not a valid IPv4 address; use 127.0.0.1"),
        ("10.255.255.1", "it is not an address of this machine"),
        (
            "no-such-host.invalid",
            "cannot listen on 'no-such-host.invalid': the name does not resolve",
        ),
    ],
)
def test_a_host_that_is_not_this_machine_fails_fast(host, message):
    with pytest.raises(GuiStartError, match="0.0.0.0 \\(every network interface\\)") as error:
        check_host(host)
    assert message in str(error.value)
    app = App("cartpole", "ps", host=host, num_workers=1)
    with pytest.raises(GuiStartError):
        app.start()
    assert not app.running


@pytest.mark.parametrize(
    ("token", "message"),
    [
        ("", "token must not be empty or blank (it would let every URL in)"),
        ("   ", "token must not be empty or blank"),
        (
            "a/b/c/d/e/f",
            "token may only hold the URL-safe characters A-Z, a-z, 0-9, '_' and '-', got "
            "'a/b/c/d/e/f'",
        ),
        ("two words here", "with ' '"),
        ("tok?en=1#frag", "with '#', '=', '?'"),
        ("..........", "with '.'"),
        ("tökentöken", "with 'ö'"),
        ("short", "token must be 8 to 128 characters long, got 5 characters"),
        ("x" * 129, "token must be 8 to 128 characters long, got 129"),
        (12345678, "token must be a string"),
    ],
)
def test_a_token_that_is_blank_or_not_url_safe_is_refused(token, message):
    with pytest.raises(ConfigError) as error:
        check_token(token, "0.0.0.0")
    assert message in str(error.value)
    with pytest.raises(ConfigError):
        App("cartpole", "ps", host="0.0.0.0", token=token, num_workers=1)  # type: ignore[arg-type]
    with pytest.raises(ConfigError):
        App("cartpole", "ps", token=token, gui=False, num_workers=1)  # type: ignore[arg-type]


def test_a_token_is_kept_generated_beyond_loopback_and_optional_on_loopback():
    assert check_token("s3cret-token_OK", "0.0.0.0") == "s3cret-token_OK"
    generated = check_token(None, "0.0.0.0")
    assert generated is not None and check_token(generated, "0.0.0.0") == generated
    assert check_token(None, "127.0.0.1") is None
    assert check_token(None, "0.0.0.0", generate=False) is None


def test_an_empty_token_on_the_command_line_exits_2(capsys):
    assert (
        launch.main(["--host", "0.0.0.0", "--token", "", "--headless", "--duration", "0.01"]) == 2
    )
    err = capsys.readouterr().err
    assert "token must not be empty or blank" in err and "Traceback" not in err


def test_loopback_addresses():
    assert all(
        is_loopback(h)
        for h in ("localhost", "127.0.0.1", "127.1.2.3", "::1", "[::1]", "app.localhost")
    )
    assert not any(
        is_loopback(h)
        for h in ("0.0.0.0", "::", "192.168.1.5", "example.com", "localhost.evil.example")
    )


def handshake(path: str = "/", **headers: str) -> Request:
    return Request(path, Headers(**{"Upgrade": "websocket", **headers}))


def test_the_policy_without_a_token():
    policy = AccessPolicy()
    assert policy.refusal(handshake(Host="127.0.0.1:8080", Origin="http://127.0.0.1:8080")) is None
    # an SSH tunnel
    assert policy.refusal(handshake(Host="localhost:9000", Origin="http://localhost:9000")) is None
    assert policy.refusal(handshake(Host="[::1]:8080", Origin="http://[::1]:8080")) is None
    assert policy.refusal(handshake(Host="127.0.0.1:8080")) is None  # no Origin: not a browser
    assert "cross-origin" in policy.refusal(handshake(Host="127.0.0.1:8080", Origin="null"))
    assert "cross-origin" in policy.refusal(
        handshake(Host="127.0.0.1:8080", Origin="http://127.0.0.1:8081")
    )
    assert "only answers loopback" in policy.refusal(
        handshake(Host="evil.example:8080", Origin="http://evil.example:8080")
    )
    two_hosts = Request(
        "/", Headers([("Upgrade", "websocket"), ("Host", "127.0.0.1:1"), ("Host", "evil.example")])
    )
    assert "expected one Host" in policy.refusal(two_hosts)


def test_the_policy_with_a_token():
    policy = AccessPolicy("tok")
    assert (
        policy.refusal(handshake("/tok", Host="10.0.0.2:8080", Origin="http://10.0.0.2:8080"))
        is None
    )
    assert policy.refusal(handshake("/tok", Host="10.0.0.2:8080")) is None
    assert "access token" in policy.refusal(handshake("/", Host="10.0.0.2:8080"))
    assert "access token" in policy.refusal(handshake("/tokx", Host="10.0.0.2:8080"))
    assert "cross-origin" in policy.refusal(
        handshake("/tok", Host="10.0.0.2:8080", Origin="http://evil.example")
    )
    page = Request("/tok/", Headers())
    assert policy.page_request(page).path == "/"  # type: ignore[union-attr]
    assert "needs its access token" in policy.page_request(Request("/", Headers()))  # type: ignore[operator]


def test_replay_follows_the_apps_access_rules(port, tmp_path):
    h5py = pytest.importorskip("h5py")
    import json

    import numpy as np

    from judo.runtime.gui.replay import Replay

    path = tmp_path / "cartpole.h5"
    with h5py.File(path, "w") as file:  # a one-demo cartpole file in collect's layout
        file.create_group("data").attrs["env_args"] = json.dumps(
            {"task": "cartpole", "optimizer": "ps", "plant_timestep": 0.01}
        )
        file["data/demo_0/obs/qpos"], file["data/demo_0/plan/times"] = np.zeros((5, 2)), np.zeros(0)
        file["data/demo_0"].attrs.update({"seed": 0, "metrics": "{}", "success": False})
    assert Replay(path).token is None  # loopback: no token, as the app
    with pytest.raises(ConfigError, match="token must not be empty or blank"):
        Replay(path, host="0.0.0.0", token=" ")
    replay = Replay(path, host="0.0.0.0", port=port)
    # generated beyond loopback, as the app's
    assert replay.token is not None and len(replay.token) >= 20
    replay.start()
    try:
        assert replay.url == f"http://localhost:{port}/{replay.token}"
        assert refused(port) == 403  # even a local program needs the token
        assert refused(port, path="/wrong-token", origin=f"http://127.0.0.1:{port}") == 403
        with open_websocket(
            port, path=f"/{replay.token}", origin=f"http://127.0.0.1:{port}"
        ) as websocket:
            assert websocket.recv(timeout=10)
        with urllib.request.urlopen(
            replay.url.replace("localhost", "127.0.0.1"), timeout=10
        ) as page:
            assert page.status == 200
    finally:
        replay.stop()
