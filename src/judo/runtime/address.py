"""Where the GUI listens: a port in range, an address of this machine, and whether it is
loopback-only.

Checked before the viser server starts, so a bad `--port` or `--host` ends the run with a message
instead of a traceback in the server thread and a hang.
"""

import ipaddress
import re
import secrets
import socket
import threading

from judo.core.errors import ConfigError, GuiStartError

PORT_RANGE = (0, 65535)
"""Valid TCP ports; 0 lets the system pick a free one."""
RESOLVE_TIMEOUT = 3.0
"""Seconds to wait for a host name to resolve before giving up on it."""
LOCAL_HOSTS_HINT = "127.0.0.1 (this machine only, the default) or 0.0.0.0 (every network interface)"
TOKEN_LENGTH = (8, 128)
"""Shortest and longest access token accepted, in characters."""
TOKEN_ALPHABET = "A-Z, a-z, 0-9, '_' and '-'"
"""The URL-safe characters a token may hold (those of `secrets.token_urlsafe`), so its URL always
opens."""
_TOKEN_PATTERN = re.compile(r"[A-Za-z0-9_-]+")


def check_port(port: object) -> int:
    """`port` if it is an integer in 0..65535, else raise ConfigError."""
    low, high = PORT_RANGE
    if isinstance(port, bool) or not isinstance(port, int) or not low <= port <= high:
        raise ConfigError(
            f"port must be an integer in {low}..{high} (0 picks a free port), got {port!r}"
        )
    return port


def is_loopback(host: str) -> bool:
    """True if `host` (a name or an address, IPv6 with or without brackets) only reaches this
    machine."""
    host = host.strip("[]").lower()
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def new_token() -> str:
    """A fresh random access token for the GUI's URL (22 URL-safe characters, 128 bits)."""
    return secrets.token_urlsafe(16)


def check_token(token: object, host: str, *, generate: bool = True) -> str | None:
    """The GUI's access token: `token` if it is URL-safe, a fresh one when it is None, `generate` is
    set (a GUI is served) and `host` reaches beyond this machine, else None (no token).

    Raises ConfigError for an empty or blank token (which would let every URL in), a token outside
    `TOKEN_ALPHABET` (its URL could never be opened) or one whose length is outside `TOKEN_LENGTH`.
    """
    if token is None:
        return new_token() if generate and not is_loopback(host) else None
    low, high = TOKEN_LENGTH
    shown = repr(token)[:200]
    if not isinstance(token, str):
        raise ConfigError(
            f"token must be a string of {low} to {high} characters, got {type(token).__name__} "
            f"{shown}"
        )
    if not token.strip():
        raise ConfigError(
            f"token must not be empty or blank (it would let every URL in), got {shown}; "
            "leave it out to get a generated one"
        )
    if not _TOKEN_PATTERN.fullmatch(token):
        bad = sorted({c for c in token if not _TOKEN_PATTERN.fullmatch(c)})
        raise ConfigError(
            f"token may only hold the URL-safe characters {TOKEN_ALPHABET}, got {shown} "
            f"(with {', '.join(map(repr, bad))[:200]})"
        )
    if not low <= len(token) <= high:
        raise ConfigError(
            f"token must be {low} to {high} characters long, got {len(token)} characters"
        )
    return token


def check_host(host: str, timeout: float = RESOLVE_TIMEOUT) -> None:
    """Raise GuiStartError unless `host` resolves, within `timeout` s, to addresses of this
    machine."""
    if re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise GuiStartError(
                f"cannot listen on {host!r}: not a valid IPv4 address; use {LOCAL_HOSTS_HINT}"
            ) from None
    addresses = _resolve(host, timeout)
    for family, kind, proto, _, address in addresses:
        with socket.socket(family, kind, proto) as sock:
            try:
                sock.bind((address[0], 0, *address[2:]))
            except OSError as err:
                raise GuiStartError(
                    f"cannot listen on {host!r} ({address[0]}): {err.strerror or err}; "
                    f"it is not an address of this machine. Use {LOCAL_HOSTS_HINT}"
                ) from None


def _resolve(host: str, timeout: float) -> list:
    """getaddrinfo(host) in a daemon thread, so a name server that does not answer cannot hang the
    app."""
    found: list = []
    failure: list[BaseException] = []

    def resolve() -> None:
        try:
            found.extend(socket.getaddrinfo(host, None, type=socket.SOCK_STREAM))
        except (OSError, UnicodeError) as err:
            failure.append(err)

    thread = threading.Thread(target=resolve, name="judo-resolve-host", daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive():
        raise GuiStartError(
            f"cannot listen on {host!r}: the name did not resolve within {timeout:g} s; use "
            f"{LOCAL_HOSTS_HINT}"
        )
    if failure or not found:
        reason = failure[0] if failure else "no address"
        raise GuiStartError(
            f"cannot listen on {host!r}: the name does not resolve ({reason}); use "
            f"{LOCAL_HOSTS_HINT}"
        )
    return found
