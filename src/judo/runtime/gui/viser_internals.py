"""The one module that reaches into viser's private internals: every other GUI module uses viser's
public API.

viser's public API lacks four things the GUI needs, so judo relies on viser's private code for them:

- a hook into the websocket handshake (the access policy, `guarded_handshakes`);
- a hook in front of viser's handling of a client's message (widget edits checked before viser
  applies them, share requests refused: `viser_gui_update_handler`, `replace_handler`);
- a widget handle by the uuid a message names, and a message to one client only (`widget_by_uuid`,
  `send_widget_value`);
- purging the tombstones of removed widgets and scene nodes (`purge_removed`).

These internals can change in any viser release. `check_viser()` runs before the server starts and
`check_server()` right after: if the installed viser lacks any of them, the GUI does not start and
GuiStartError names the installed viser, TESTED_VISER and what is missing. Never run unguarded,
never degrade silently. Tested on viser 1.1.1; viser 1.1.0's source of every internal named here is
the same.
"""

import contextlib
import importlib
import importlib.metadata
import threading
import types
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import viser
import viser.infra
import websockets.asyncio.server

from judo.core.errors import GuiStartError

if TYPE_CHECKING:
    from viser._messages import GuiUpdateMessage

TESTED_VISER = ">=1.1,<1.2"
"""The viser releases judo is tested with (pyproject.toml pins the same range)."""
VISER_HANDLER = "WebsockServer._background_worker.<locals>.ws_handler"
"""`__qualname__` of the websocket handler viser's server thread serves: the `serve` call to
guard."""
_BY_UUID = "viser.GuiApi._gui_input_handle_from_uuid"
MESSAGES = ("GuiUpdateMessage", "ShareUrlRequest")
"""The classes of viser._messages judo handles or sends."""

Handler = Callable[[viser.infra.ClientId, "GuiUpdateMessage"], Any]
"""A handler of one kind of message from a client: (client id, message) -> None or an awaitable."""

_starting = threading.Lock()


def viser_version() -> str:
    """The installed viser's version, as its package metadata says."""
    try:
        return importlib.metadata.version("viser")
    except importlib.metadata.PackageNotFoundError:
        return getattr(viser, "__version__", "(unknown version)")


def unsupported(missing: str) -> GuiStartError:
    """The error for a viser that lacks `missing`, an internal the GUI relies on."""
    return GuiStartError(
        f"the GUI cannot start on the installed viser {viser_version()}: it lacks {missing}, "
        "which judo relies on. "
        f"judo is tested with viser{TESTED_VISER}; install one with: pip install "
        f'"viser{TESTED_VISER}"'
    )


def check_viser() -> None:
    """Raise GuiStartError (see `unsupported`) unless the viser classes have every internal the GUI
    relies on.

    Runs before the server starts. What only a running server has is checked by `check_server`."""
    messages = _messages_module()
    for name in MESSAGES:
        _require(messages, name, f"viser._messages.{name}")
    _require(viser.infra, "WebsockServer", "viser.infra.WebsockServer")
    for name in ("register_handler", "unregister_handler", "_background_worker"):
        _require(viser.infra.WebsockServer, name, f"viser.infra.WebsockServer.{name}")
    _require(viser.infra, "WebsockClientConnection", "viser.infra.WebsockClientConnection")
    _require(
        viser.infra.WebsockClientConnection,
        "queue_message",
        "viser.infra.WebsockClientConnection.queue_message",
    )
    _require(
        viser.ViserServer, "_run_garbage_collector", "viser.ViserServer._run_garbage_collector"
    )
    _require(viser.GuiApi, "_handle_gui_updates", "viser.GuiApi._handle_gui_updates")
    if "_websock_connection" not in _code_names(viser.ClientHandle.__init__):
        raise unsupported(
            "viser.ClientHandle._websock_connection (ClientHandle.__init__ no longer sets it)"
        )
    if VISER_HANDLER not in _nested_qualnames(viser.infra.WebsockServer._background_worker):
        raise unsupported(f"the websocket handler {VISER_HANDLER} (the handshake judo guards)")


def check_server(server: viser.ViserServer) -> None:
    """Raise GuiStartError (see `unsupported`) unless the running `server` has every internal the
    GUI relies on: its websocket server's message handlers (viser's own for widget edits and share
    requests) and its widgets by uuid."""
    websock = _require(server, "_websock_server", "viser.ViserServer._websock_server")
    handlers = _require(
        websock, "_incoming_handlers", "viser.infra.WebsockServer._incoming_handlers"
    )
    if not isinstance(handlers, dict):
        raise unsupported(
            "viser.infra.WebsockServer._incoming_handlers as a dict of handlers by message class"
        )
    messages = _messages_module()
    own = _require(server.gui, "_handle_gui_updates", "viser.GuiApi._handle_gui_updates")
    if handlers.get(messages.GuiUpdateMessage) != [own]:
        raise unsupported("viser.GuiApi._handle_gui_updates as the one handler of GuiUpdateMessage")
    if not handlers.get(messages.ShareUrlRequest):
        raise unsupported(
            "a handler of ShareUrlRequest in viser.infra.WebsockServer._incoming_handlers"
        )
    if not isinstance(_require(server.gui, "_gui_input_handle_from_uuid", _BY_UUID), dict):
        raise unsupported(f"{_BY_UUID} as a dict of widget handles by uuid")


def viser_gui_update_handler(server: viser.ViserServer) -> Handler:
    """viser's own handler of widget edits (`GuiUpdateMessage`) on `server`, the one
    `guard_gui_updates` wraps.

    Why: viser applies and broadcasts a client's edit with no public hook to check it first. Relies
    on: `GuiApi._handle_gui_updates` being the handler `server` registered (checked by
    `check_server`)."""
    return server.gui._handle_gui_updates


def replace_handler(
    server: viser.ViserServer, message: str, handler: Callable[[viser.infra.ClientId, Any], Any]
) -> None:
    """Make `handler` the only handler of the client messages of class `viser._messages.<message>`
    on `server`.

    Why: viser has no public API to intercept a client's messages (widget edits, share requests).
    Relies on: `ViserServer._websock_server` and its `unregister_handler` / `register_handler`."""
    message_class = getattr(_messages_module(), message)
    server._websock_server.unregister_handler(message_class)
    server._websock_server.register_handler(message_class, handler)


def widget_by_uuid(server: viser.ViserServer, uuid: str) -> Any:
    """The handle of `server`'s input widget `uuid` (the id a `GuiUpdateMessage` names), or None.

    Why: a widget edit names its widget by uuid, and viser's handles show no uuid publicly. Relies
    on: `GuiApi._gui_input_handle_from_uuid`, the dict viser's own handler looks edits up in."""
    return server.gui._gui_input_handle_from_uuid.get(uuid)


def send_widget_value(client: viser.ClientHandle, uuid: str, value: Any) -> None:
    """Send `client`'s page alone widget `uuid`'s `value` (the page shows it in place of what it
    sent).

    Why: viser's public setters (`handle.value = ...`) broadcast to every page; a refused edit must
    reach only its sender. Relies on: `ClientHandle._websock_connection.queue_message` and
    `viser._messages.GuiUpdateMessage(uuid, updates)`."""
    client._websock_connection.queue_message(
        _messages_module().GuiUpdateMessage(uuid, {"value": value})
    )


def purge_removed(server: viser.ViserServer) -> None:
    """Drop from `server`'s saved messages the tombstones of removed widgets and scene nodes.

    Why: viser keeps them for pages that connect later and purges them only when one does, so an app
    that rebuilds its panels and scene on each switch would grow its memory; there is no public
    purge. Relies on: `ViserServer._run_garbage_collector()`."""
    server._run_garbage_collector()


@contextlib.contextmanager
def guarded_handshakes(
    guard: Callable[[Any], Any], guarded: list[bool], timeout: float
) -> Iterator[None]:
    """While inside, viser's server thread serves websockets with `guard(process_request)` as the
    `process_request` of its `serve` call; `guarded` gets one True per call guarded.

    Why: viser has no public hook into its websocket handshake (the access policy checks the token
    and origin there). Relies on: viser calling `websockets.asyncio.server.serve` from its server
    thread, with `VISER_HANDLER` as the handler. `serve` is swapped only inside, under a lock
    (raises GuiStartError if another start holds it for `timeout` s); the caller checks `guarded`
    after the start, so a viser that serves differently never runs without the guard."""
    module: Any = websockets.asyncio.server  # typed Any: its `serve` is swapped for the start
    serve = module.serve

    def guarded_serve(handler, *args, process_request=None, **kwargs):
        if getattr(handler, "__qualname__", "") == VISER_HANDLER:
            process_request = guard(process_request)
            guarded.append(True)
        return serve(handler, *args, process_request=process_request, **kwargs)

    if not _starting.acquire(timeout=timeout):
        raise GuiStartError("another GUI server is still starting in this process")
    module.serve = guarded_serve
    try:
        yield
    finally:
        module.serve = serve
        _starting.release()


def _messages_module() -> Any:
    """viser._messages, or GuiStartError if viser has none."""
    try:
        return importlib.import_module("viser._messages")
    except ImportError as err:
        raise unsupported("the module viser._messages") from err


def _require(owner: object, name: str, what: str) -> Any:
    """`owner`'s attribute `name`, or GuiStartError naming `what`."""
    try:
        return getattr(owner, name)
    except AttributeError:
        raise unsupported(what) from None


def _code_names(function: Any) -> tuple[str, ...]:
    """The attribute and global names `function`'s code uses (empty if it has no code)."""
    code = getattr(function, "__code__", None)
    return code.co_names if isinstance(code, types.CodeType) else ()


def _nested_qualnames(function: Any) -> set[str]:
    """`__qualname__`s of the functions defined directly in `function` (empty if it has no code)."""
    code = getattr(function, "__code__", None)
    if not isinstance(code, types.CodeType):
        return set()
    outer = getattr(function, "__qualname__", "")
    return {
        f"{outer}.<locals>.{const.co_name}"
        for const in code.co_consts
        if isinstance(const, types.CodeType)
    }
