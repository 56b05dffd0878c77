"""The app's frontend: the GUI given to the App, which draws it on its event loop and never imports it.

A frontend is anything with `url`, `update()` (one frame, about 30 Hz) and `close()`, built from the App's command
port (`judo.runtime.commands.AppPort`) by a `FrontendFactory`. judo's own is the viser GUI (`judo.runtime.gui.Gui`),
looked up by name (VISER_FRONTEND) when an App is started with gui=True, so viser is imported only then.
"""

import importlib
import logging
from collections.abc import Callable
from typing import Protocol

from judo.runtime.address import is_loopback
from judo.runtime.commands import AppPort

logger = logging.getLogger("judo.app")

VISER_FRONTEND = "judo.runtime.gui:Gui"
"""module:class of the browser GUI built for gui=True."""


class Frontend(Protocol):
    """A GUI the app draws on its event loop."""

    @property
    def url(self) -> str:
        """Where a browser finds it."""
        ...

    def update(self) -> None:
        """Draw one frame: follow the app's state."""
        ...

    def close(self) -> None:
        """Stop serving."""
        ...


FrontendFactory = Callable[[AppPort], Frontend]
"""Builds a frontend of the App (its command port), on the app's event loop."""


class ServedApp(AppPort, Protocol):
    """An App with the settings of the GUI's server."""

    host: str
    port: int
    token: str | None
    share: bool


def viser_frontend(app: ServedApp) -> Callable[[], Frontend]:
    """Builds judo's viser GUI of `app` at http://app.host:app.port (the next free port if it is taken), warning
    when it listens beyond loopback. The function raises GuiStartError if the server cannot start."""

    def make() -> Frontend:
        module, _, name = VISER_FRONTEND.partition(":")
        gui_class = getattr(importlib.import_module(module), name)
        gui = gui_class(app, app.host, app.port, token=app.token, share=app.share)
        warn_if_exposed(app.host, gui.server.get_port())
        logger.info("GUI at %s", gui.url)
        return gui

    return make


def warn_if_exposed(host: str, port: int) -> None:
    """Log what a GUI listening on `host` beyond loopback exposes."""
    if is_loopback(host):
        return
    logger.warning(
        "the GUI listens on %s (%s): anyone who can reach port %d of this machine and has the URL with its "
        "token can change every config, switch the task, pause the plant or reset it, a real robot too. "
        "Prefer the default 127.0.0.1 and an SSH tunnel (docs/gui.md).",
        host,
        "every network interface" if host in ("0.0.0.0", "::") else "reachable from the network",
        port,
    )
