"""Start the GUI's viser server: on a checked address, with `AccessPolicy` on every handshake, the
share button only on request, and an error, never a hang, when it cannot start.

viser offers no hook into its websocket handshake, so `start_server` wraps the one
`websockets.asyncio.server.serve` call viser's server thread makes while the server starts (and
only that call: it is recognised by viser's handler), adding the policy in front of viser's own
`process_request`. The wrapper is in place only during the start, under a lock. Widget edits from
clients pass `guard_gui_updates` (incoming.py) before viser applies and broadcasts them. These hooks
rely on viser's private internals, all reached through viser_internals.py and checked there before
and right after the start: a viser without them is refused with GuiStartError, never run unguarded.
"""

import logging
import threading

import viser

from judo.core.errors import GuiStartError
from judo.runtime.address import check_host, check_port, is_loopback
from judo.runtime.gui.access import AccessPolicy
from judo.runtime.gui.incoming import guard_gui_updates
from judo.runtime.gui.viser_internals import (
    VISER_HANDLER,
    check_server,
    check_viser,
    guarded_handshakes,
    replace_handler,
    unsupported,
)

logger = logging.getLogger("judo.gui")

START_TIMEOUT = 20.0
"""Seconds to wait for the server to start listening before reporting that it could not."""
FILL_LIGHT = {"sky_color": (255, 255, 255), "ground_color": (90, 90, 90), "intensity": 1.5}
"""The hemisphere light that stands in for viser's environment map: white from above (+z), dim grey
from below."""


def start_server(
    host: str, port: int, *, token: str | None, share: bool, label: str
) -> viser.ViserServer:
    """A running viser server on `host`:`port` (the next free port if it is taken).

    Handshakes must pass `AccessPolicy(token)`. The share button (a public URL through
    share.viser.studio) is shown, and clients' share requests honoured, only if `share`. Raises
    ConfigError for a port out of range, GuiStartError for an address that is not this machine's, a
    server that does not start within START_TIMEOUT seconds, or a viser that lacks an internal judo
    relies on (the message names the installed viser and the range judo is tested with).
    """
    check_port(port)
    check_host(host)
    check_viser()
    if token is None and not is_loopback(host):
        raise GuiStartError(
            f"the GUI on {host!r} reaches beyond this machine and needs an access token"
        )
    policy = AccessPolicy(token)
    guarded: list[bool] = []
    started: list[viser.ViserServer] = []
    failed: list[BaseException] = []

    def build() -> None:
        try:
            with guarded_handshakes(policy.guard, guarded, START_TIMEOUT):
                started.append(viser.ViserServer(host=host, port=port, label=label, verbose=False))
        except BaseException as err:  # reported to the caller below
            failed.append(err)

    # viser waits forever for a server thread that died (e.g. on a port bind() refuses): start it
    # from a helper thread and stop waiting after START_TIMEOUT.
    thread = threading.Thread(target=build, name="judo-gui-start", daemon=True)
    thread.start()
    thread.join(START_TIMEOUT)
    if failed:
        raise GuiStartError(
            f"the GUI server could not start on {host}:{port}: {failed[0]}"
        ) from failed[0]
    if not started:
        raise GuiStartError(
            f"the GUI server did not start on {host}:{port} within {START_TIMEOUT:g} s"
        )
    server = started[0]
    try:
        if not guarded:  # a viser release that serves differently: never run without the policy
            raise unsupported(
                f"a websocket served with the handler {VISER_HANDLER} (the handshake judo guards)"
            )
        check_server(server)
        guard_gui_updates(server)  # one client's edit can never close other pages (see incoming.py)
        server.gui.configure_theme(show_share_button=share)
        light_without_environment_map(server)
        if not share:  # a client could still send the request the hidden button sends
            replace_handler(server, "ShareUrlRequest", _refuse_share)
    except BaseException:  # never leave a server running that start_server did not hand over
        server.stop()
        raise
    return server


def light_without_environment_map(server: viser.ViserServer) -> None:
    """Light `server`'s scene with viser's two default directional lights and `FILL_LIGHT`, and no
    environment map.

    Until viser's environment map has loaded and faded in, its page draws the whole 3-D view at 5 %
    opacity: in a browser that renders WebGL in software (a VM, a remote desktop, headless Chromium)
    the scene then stayed washed out for the first 10 to 30 seconds. Without a map the view is
    opaque from the first frame with the scene in it.
    """
    server.scene.configure_environment_map(hdri=None)
    server.scene.add_light_hemisphere("/judo_fill_light", position=(0.0, 0.0, 1.0), **FILL_LIGHT)


def gui_url(server: viser.ViserServer, token: str | None) -> str:
    """Where a browser finds `server`'s GUI: http://HOST:PORT, then /TOKEN when it has one (every
    interface, 0.0.0.0 or ::, is shown as localhost; an IPv6 address in brackets)."""
    host = server.get_host()
    host = "localhost" if host in ("0.0.0.0", "::") else f"[{host}]" if ":" in host else host
    return f"http://{host}:{server.get_port()}" + (f"/{token}" if token else "")


def _refuse_share(client_id: int, message: object) -> None:
    logger.warning(
        "client %d asked for a public share URL; refused (start the app with --share to allow it)",
        client_id,
    )
