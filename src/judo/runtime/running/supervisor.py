"""The supervisor: one asyncio event loop that runs the planner runner, the plant thread's watch and
the frontend's frames until a stop, then stops every part in order; the frontend's factory and the
exit guard (the package's docstring tells who runs what)."""

import asyncio
import atexit
import importlib
import logging
import signal
import threading
import weakref
from collections.abc import Callable, Coroutine
from typing import Any, Protocol

from judo.runtime.address import is_loopback
from judo.runtime.app_state import AppState
from judo.runtime.command_port import AppPort
from judo.runtime.live_recording import Recordings
from judo.runtime.running.planner import PlannerRunner
from judo.runtime.running.plant import PlantRunner
from judo.runtime.status import Reports
from judo.safety.stop import StopLatch

logger = logging.getLogger("judo.app")

VISER_FRONTEND = "judo.runtime.gui.gui:Gui"
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
    """Builds judo's viser GUI of `app` at http://app.host:app.port (the next free port if it is
    taken), warning when it listens beyond loopback. The function raises GuiStartError if the server
    cannot start."""

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
        "the GUI listens on %s (%s): anyone who can reach port %d of this machine and has "
        "the URL with its "
        "token can change every config, switch the task, pause the plant or reset it, a real "
        "robot too. "
        "Prefer the default 127.0.0.1 and an SSH tunnel (docs/gui.md).",
        host,
        "every network interface" if host in ("0.0.0.0", "::") else "reachable from the network",
        port,
    )


logger = logging.getLogger("judo.app")

GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
PLANT_THREAD_JOIN = 1.0
"""Seconds a stop waits for the plant thread to halt the plant and end; a driver blocked longer is
left."""


class Supervisor:
    """Runs an App's parts until a stop (see the package's docstring).

    Args:
        state: the app's state (its stop signal, the session in use).
        plant: the plant runner, started here.
        planner: the planner runner, run here.
        recordings: written at the stop.
        reports: the status line.
        system_call_limit: seconds a System call may block before it is reported and the robot
            halted.
        make_frontend: builds the GUI on the event loop's thread (None: no GUI); raises if it cannot
            start.
        stop_latch: the latched stop, engaged by SIGUSR1 where signals are handled, and said at
            start when latched.
    """

    def __init__(
        self,
        *,
        state: AppState,
        plant: PlantRunner,
        planner: PlannerRunner,
        recordings: Recordings,
        reports: Reports,
        system_call_limit: float,
        make_frontend: Callable[[], Frontend] | None,
        stop_latch: StopLatch | None = None,
    ) -> None:
        self._state, self._plant, self._planner = state, plant, planner
        self._recordings, self._reports = recordings, reports
        self._system_call_limit, self._make_frontend, self._stop_latch = (
            system_call_limit,
            make_frontend,
            stop_latch,
        )
        self.frontend: Frontend | None = None  # while the loops run with a GUI
        self.start_error: BaseException | None = None  # why the GUI could not start
        self.ready = threading.Event()  # the loops run (or failed to start)
        self.finished = threading.Event()  # every part has stopped

    async def main(self, handle_signals: bool = False) -> None:
        """Run every part until a stop, then stop them in order. Raises what kept the GUI from
        starting."""
        state, loop = self._state, asyncio.get_running_loop()
        state.stop.bind()
        if handle_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, state.stop.set)
            if (latch := self._stop_latch) is not None:
                loop.add_signal_handler(signal.SIGUSR1, latch.engage, "SIGUSR1")
        if self._stop_latch is not None:
            self._stop_latch.listen()  # a robot link's e-stop reaches it while the app runs
        running = False
        try:
            if self._make_frontend is not None:
                self.frontend = self._make_frontend()
            self._plant.start()
            coroutines: list[Coroutine[Any, Any, None]] = [
                self._planner.run(),
                self._planner.show_late_cycles(),
                self._plant.watch(self._system_call_limit),
            ]
            if self.frontend is not None:
                coroutines.append(self._draw_frontend(self.frontend))
            self._reports.report(self._reports.running())
            if self._stop_latch is not None and self._stop_latch.latched:
                self._reports.report(self._stop_latch.start_line(), "warning")
            tasks = [asyncio.create_task(coroutine) for coroutine in coroutines]
            running = True
            self.ready.set()
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            state.stop.set()  # a loop only returns when asked to stop, or on a bug: end the others
            for result in await asyncio.gather(*tasks, return_exceptions=True):
                if isinstance(result, BaseException):
                    logger.error("a judo loop failed", exc_info=result)
        except BaseException as err:
            if not running:  # the GUI did not start: start() raises this once `ready` is set
                self.start_error = err
            raise
        finally:
            self._stop_in_order()
            if handle_signals:
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
                    loop.remove_signal_handler(sig)
            state.stop.unbind()
            self.finished.set()

    def _stop_in_order(self) -> None:
        state = self._state
        state.stop.set()
        self.ready.set()
        if self._plant.thread.ident is not None:
            self._plant.thread.join(PLANT_THREAD_JOIN)
        # a driver blocked in a call is left to return on its own thread
        state.session.closed_loop.calls.close()
        self._recordings.finish("the app stopped")
        if self.frontend is not None:
            self.frontend.close()
        self._planner.close()
        state.session.close()
        if self._stop_latch is not None:
            self._stop_latch.close()

    async def _draw_frontend(self, frontend: Frontend) -> None:
        loop = asyncio.get_running_loop()
        while not self._state.stop.is_set():
            start = loop.time()
            try:
                frontend.update()
            except Exception as err:
                self._reports.report(f"GUI update failed: {type(err).__name__}: {err}", "error")
            await self._state.stop.sleep(start + GUI_PERIOD - loop.time())


class Stoppable(Protocol):
    """What the hook needs of an App."""

    def stop(self, timeout: float | None = ...) -> None: ...


EXIT_STOP_TIMEOUT = 5.0
"""Seconds the exit hook waits for each running App to stop (its planning cycle in flight to
end)."""

_running: "weakref.WeakSet[Stoppable]" = weakref.WeakSet()
_lock = threading.Lock()


def stop_at_exit(app: Stoppable) -> None:
    """Have `app` stopped (`app.stop(EXIT_STOP_TIMEOUT)`) at interpreter exit if it is still running
    then.

    Call it once the app has started; stopping an app that already stopped does nothing harmful."""
    with _lock:
        _running.add(app)
        atexit.unregister(stop_running_apps)
        atexit.register(stop_running_apps)


def stop_running_apps() -> None:
    """Stop every registered App, each waited for at most EXIT_STOP_TIMEOUT seconds."""
    with _lock:
        apps = list(_running)
        _running.clear()
    for app in apps:
        try:
            app.stop(timeout=EXIT_STOP_TIMEOUT)
        except Exception:  # at exit, one app failing to stop must not skip the others
            pass
