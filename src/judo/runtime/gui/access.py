"""Who may open the GUI's websocket: same-origin browsers, and with a token set, only those who hold
it.

The websocket is the GUI's only channel of control (every slider, reset and switch travels over it),
so every opening handshake passes `AccessPolicy.check` before it is accepted:

- a browser sends an `Origin` header; it must name the same host and port the request was sent to
  (`Host`), so a page from another site open in the user's own browser cannot drive the app;
- without a token (a GUI on a loopback address) the `Host` must be a loopback name or address, so a
  DNS-rebinding page (evil.example resolving to 127.0.0.1) is refused too;
- with a token (set with `--token`, or generated when listening beyond loopback) the request path
  must begin with it: the GUI is opened at http://HOST:PORT/TOKEN and viser's client connects its
  websocket to ws://HOST:PORT/TOKEN.

A client that sends no `Origin` is not a browser (browsers always send one on a websocket); it is
accepted on a loopback GUI without a token, like any local program that could run judo itself.
"""

import hmac
import logging
from dataclasses import dataclass, replace
from urllib.parse import urlsplit

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from judo.runtime.address import is_loopback

logger = logging.getLogger("judo.gui")


def _hostname(authority: str) -> str:
    """The host part of `authority` ("host:port", "[::1]:port" or "host")."""
    return urlsplit(f"//{authority}").hostname or ""


@dataclass(frozen=True)
class AccessPolicy:
    """The rules every websocket handshake and page request of one GUI server is checked against.

    Attributes:
        token: the secret the request path must begin with, or None for a loopback-only GUI.
    """

    token: str | None = None

    def refusal(self, request: Request) -> str | None:
        """Why the websocket handshake `request` is refused, or None if it is accepted."""
        hosts, origins = request.headers.get_all("Host"), request.headers.get_all("Origin")
        if len(hosts) != 1 or len(origins) > 1:
            return (
                "websocket refused: expected one Host and at most one Origin header, got "
                f"{hosts} and {origins}"
            )
        host, origin = hosts[0], (origins[0] if origins else None)
        if origin is not None and urlsplit(origin).netloc.lower() != host.lower():
            return (
                f"cross-origin websocket refused: Origin {origin!r} is not the GUI's own address "
                f"{host!r}"
            )
        if self.token is None:
            if not is_loopback(_hostname(host)):
                return (
                    f"websocket to {host!r} refused: without a token the GUI only answers "
                    "loopback addresses "
                    "(localhost, 127.0.0.1, [::1]); use one, or restart with --token"
                )
            return None
        if not self.has_token(request.path):
            return "websocket refused: the GUI needs its access token; open the URL the app printed"
        return None

    def has_token(self, path: str) -> bool:
        """True if `path`'s first segment is the token (compared in constant time)."""
        assert self.token is not None
        first = path.partition("?")[0].lstrip("/").partition("/")[0]
        return hmac.compare_digest(first.encode(), self.token.encode())

    def page_request(self, request: Request) -> Request | str:
        """The page request with the token removed from its path, or why it is refused.

        Only the page itself (`/`) needs the token: the other files are viser's public client."""
        if self.token is None:
            return request
        if self.has_token(request.path):
            rest = request.path.lstrip("/").partition("/")[2]
            return replace(request, path="/" + rest)
        if request.path.partition("?")[0] in ("", "/"):
            return (
                "This judo GUI needs its access token: open the URL the app printed "
                "(http://HOST:PORT/TOKEN).\n"
            )
        return request

    def guard(self, serve_files):  # viser's process_request callable, and ours
        """A websockets `process_request` hook that applies this policy, then hands page requests to
        `serve_files` (viser's own file server)."""

        def process_request(connection: ServerConnection, request: Request) -> Response | None:
            if request.headers.get("Upgrade", "").lower() == "websocket":
                reason = self.refusal(request)
                if reason is None:
                    return None
                logger.warning("%s", reason)
                return connection.respond(403, reason + "\n")
            page = self.page_request(request)
            if isinstance(page, str):
                return connection.respond(403, page)
            return serve_files(connection, page) if serve_files is not None else None

        return process_request
