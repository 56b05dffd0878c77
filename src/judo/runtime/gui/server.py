"""Start the GUI's viser server: on a checked address, with `AccessPolicy` on every handshake, the
share button only on request, and an error, never a hang, when it cannot start.

viser offers no hook into its websocket handshake, so `start_server` wraps the one
`websockets.asyncio.server.serve` call viser's server thread makes while the server starts (and
only that call: it is recognised by viser's handler), adding the policy in front of viser's own
`process_request`. The wrapper is in place only during the start, under a lock. Widget edits from
clients pass `guard_gui_updates` (incoming.py) before viser applies and broadcasts them.
"""

import contextlib
import logging
import threading
from collections.abc import Iterator

import viser
import websockets.asyncio.server
from viser import _messages as viser_messages

from judo.core.errors import GuiStartError
from judo.runtime.address import check_host, check_port, is_loopback
from judo.runtime.gui.access import AccessPolicy
from judo.runtime.gui.incoming import guard_gui_updates

logger = logging.getLogger("judo.gui")

START_TIMEOUT = 20.0
"""Seconds to wait for the server to start listening before reporting that it could not."""
VISER_HANDLER = "WebsockServer._background_worker.<locals>.ws_handler"
"""`__qualname__` of the websocket handler viser's server thread serves: the call to guard."""

_starting = threading.Lock()


def start_server(host: str, port: int, *, token: str | None, share: bool, label: str) -> viser.ViserServer:
    """A running viser server on `host`:`port` (the next free port if it is taken).

    Handshakes must pass `AccessPolicy(token)`. The share button (a public URL through
    share.viser.studio) is shown, and clients' share requests honoured, only if `share`.
    Raises ConfigError for a port out of range, GuiStartError for an address that is not this
    machine's or a server that does not start within START_TIMEOUT seconds.
    """
    check_port(port)
    check_host(host)
    if token is None and not is_loopback(host):
        raise GuiStartError(f"the GUI on {host!r} reaches beyond this machine and needs an access token")
    policy = AccessPolicy(token)
    guarded: list[bool] = []
    started: list[viser.ViserServer] = []
    failed: list[BaseException] = []

    def build() -> None:
        try:
            with _guarded_handshakes(policy, guarded):
                started.append(viser.ViserServer(host=host, port=port, label=label, verbose=False))
        except BaseException as err:  # reported to the caller below
            failed.append(err)

    # viser waits forever for a server thread that died (e.g. on a port bind() refuses): start it
    # from a helper thread and stop waiting after START_TIMEOUT.
    thread = threading.Thread(target=build, name="judo-gui-start", daemon=True)
    thread.start()
    thread.join(START_TIMEOUT)
    if failed:
        raise GuiStartError(f"the GUI server could not start on {host}:{port}: {failed[0]}") from failed[0]
    if not started:
        raise GuiStartError(f"the GUI server did not start on {host}:{port} within {START_TIMEOUT:g} s")
    server = started[0]
    if not guarded:  # a viser release that serves differently: never run without the policy
        server.stop()
        raise GuiStartError(f"cannot guard the websocket of viser {viser.__version__}; judo needs a viser it supports")
    try:
        guard_gui_updates(server)  # one client's edit can never close other pages (see incoming.py)
    except GuiStartError:
        server.stop()
        raise
    server.gui.configure_theme(show_share_button=share)
    if not share:  # a client could still send the request the hidden button sends
        server._websock_server.unregister_handler(viser_messages.ShareUrlRequest)
        server._websock_server.register_handler(viser_messages.ShareUrlRequest, _refuse_share)
    return server


def gui_url(server: viser.ViserServer, token: str | None) -> str:
    """Where a browser finds `server`'s GUI: http://HOST:PORT, then /TOKEN when it has one (every interface,
    0.0.0.0 or ::, is shown as localhost; an IPv6 address in brackets)."""
    host = server.get_host()
    host = "localhost" if host in ("0.0.0.0", "::") else f"[{host}]" if ":" in host else host
    return f"http://{host}:{server.get_port()}" + (f"/{token}" if token else "")


def _refuse_share(client_id: int, message: object) -> None:
    logger.warning(
        "client %d asked for a public share URL; refused (start the app with --share to allow it)", client_id
    )


@contextlib.contextmanager
def _guarded_handshakes(policy: AccessPolicy, guarded: list[bool]) -> Iterator[None]:
    """Put `policy` in front of the `process_request` of viser's `serve` calls made meanwhile;
    append to `guarded` for each call guarded."""
    serve = websockets.asyncio.server.serve

    def guarded_serve(handler, *args, process_request=None, **kwargs):  # noqa: ANN001, ANN202
        if getattr(handler, "__qualname__", "") == VISER_HANDLER:
            process_request = policy.guard(process_request)
            guarded.append(True)
        return serve(handler, *args, process_request=process_request, **kwargs)

    if not _starting.acquire(timeout=START_TIMEOUT):
        raise GuiStartError("another GUI server is still starting in this process")
    websockets.asyncio.server.serve = guarded_serve  # type: ignore[misc]
    try:
        yield
    finally:
        websockets.asyncio.server.serve = serve  # type: ignore[misc]
        _starting.release()
