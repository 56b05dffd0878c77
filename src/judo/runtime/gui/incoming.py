"""A guard in front of viser's handler of widget edits, so one websocket message can never take the
GUI down.

viser applies a client's `GuiUpdateMessage` to the widget's state and broadcasts it to every page
before anyone checks it. Its broadcast, and each page's, then serializes the value with msgpack,
which cannot hold an integer beyond 64 bits: `{"value": 1e20}` for an integer slider (cast by viser
to `int(1e20)`) makes every page's sender raise OverflowError, and viser closes every page with
1011. The value stays in viser's saved state, so every page opened later is closed after 0 frames.
viser also applies and keeps values from a client that never registered (sent no camera message, so
no callback runs and the app never sees the edit), values outside a dropdown's options, NaN, and
edits of properties other than `value` (a slider's `min`, a dropdown's `options`) that pages never
send.

`guard_gui_updates` replaces viser's handler with one that passes an edit on only when it comes from
a registered client, sets only `value`, and holds a value the widget can show and msgpack can carry.
A refused edit is logged once per client and its sender's page is sent the value in force again;
nothing is stored and no other page hears of it.
"""

import logging
import math
from numbers import Real
from typing import TYPE_CHECKING, Any

import viser
import viser.infra

from judo.runtime.gui.viser_internals import (
    Handler,
    replace_handler,
    send_widget_value,
    viser_gui_update_handler,
    widget_by_uuid,
)

if TYPE_CHECKING:
    from judo.runtime.gui.viser_internals import GuiUpdateMessage

logger = logging.getLogger("judo.gui")

MAX_INT = 2**53 - 1
"""Largest integer a widget accepts: the largest a browser's numbers hold exactly (msgpack stops at
2**64)."""
MAX_TEXT = 100_000
"""Most characters a text box accepts from a page."""


def guard_gui_updates(server: viser.ViserServer) -> None:
    """Put `refusal` in front of viser's handler of `GuiUpdateMessage` on `server` (whose viser
    internals `check_server` has checked)."""
    viser_handler: Handler = viser_gui_update_handler(server)
    warned: set[int] = set()

    async def guarded(client_id: viser.infra.ClientId, message: "GuiUpdateMessage") -> None:
        why = refusal(server, client_id, message)
        if why is None:
            await viser_handler(client_id, message)
            return
        if client_id not in warned:
            warned.add(client_id)
            logger.warning(
                "client %d: widget edit refused, %s (further refusals for this client are "
                "not logged)",
                client_id,
                why,
            )
        _show_value_in_force(server, client_id, message.uuid)

    replace_handler(server, "GuiUpdateMessage", guarded)


def refusal(server: viser.ViserServer, client_id: int, message: "GuiUpdateMessage") -> str | None:
    """Why `message` from client `client_id` must not reach viser, or None if it may."""
    if client_id not in server.get_clients():
        return "the client has not registered (a page registers with its first camera message)"
    updates = message.updates
    if not isinstance(updates, dict) or set(updates) != {"value"}:
        shown = (
            sorted(map(str, updates))[:10] if isinstance(updates, dict) else type(updates).__name__
        )
        return f"a page only ever sets a widget's value, got {shown}"
    handle = widget_by_uuid(server, message.uuid)
    if handle is None:
        return None  # viser ignores an edit of a widget it does not have
    return value_refusal(handle, updates["value"])


def value_refusal(handle: Any, value: Any) -> str | None:
    """Why `value` cannot be `handle`'s value, or None if it can (before viser's cast to the value's
    type)."""
    if isinstance(handle, viser.GuiButtonHandle):
        return None if value is True else f"a button only sends true, got {_shown(value)}"
    if isinstance(handle, (viser.GuiDropdownHandle, viser.GuiButtonGroupHandle)):
        options = tuple(handle.options)
        return (
            None
            if value in options
            else (f"expected one of {_shown(options)}, got {_shown(value)}")
        )
    return _like(handle.value, value)


def _like(current: Any, value: Any) -> str | None:
    """Why `value` cannot replace `current` (a widget value: bool, int, float, str or a tuple of
    them)."""
    if isinstance(current, bool):
        return None if isinstance(value, bool) else f"expected true or false, got {_shown(value)}"
    if isinstance(current, (int, float)):
        if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
            return f"expected a finite number, got {_shown(value)}"
        if isinstance(current, int) and abs(value) > MAX_INT:
            return f"expected an integer of magnitude at most {MAX_INT}, got {_shown(value)}"
        return None
    if isinstance(current, str):
        if not isinstance(value, str) or len(value) > MAX_TEXT:
            return f"expected text of at most {MAX_TEXT} characters, got {_shown(value)}"
        return None
    if isinstance(current, tuple):
        if not isinstance(value, (list, tuple)) or len(value) != len(current):
            return f"expected {len(current)} values, got {_shown(value)}"
        return next(
            (why for item, new in zip(current, value, strict=True) if (why := _like(item, new))),
            None,
        )
    return f"this widget's value is not set by pages, got {_shown(value)}"


def _show_value_in_force(server: viser.ViserServer, client_id: int, uuid: str) -> None:
    """Send client `client_id` (only) the value in force of widget `uuid`, over what its page
    shows."""
    client = server.get_clients().get(client_id)
    handle = widget_by_uuid(server, uuid)
    if client is None or handle is None:
        return
    send_widget_value(client, uuid, handle.value)


def _shown(value: Any) -> str:
    """`value` for a log line, cut to 200 characters."""
    text = repr(value)
    return text if len(text) <= 200 else text[:200] + "..."
