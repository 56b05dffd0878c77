"""The App's event loop: one asyncio loop that serves the GUI and runs the controller, plant-monitor and GUI
coroutines (`judo.runtime.loops`) beside the plant's own thread (`judo.runtime.plant_loop`) until a stop,
then tears everything down.

A stop (`stop()`, Ctrl-C, SIGTERM, the duration reached) sets `_stop` from any thread and wakes every wait;
a planning cycle still in flight is abandoned to its daemon thread rather than waited for.
"""

import asyncio
import logging
import signal
import threading

from judo.core.workers import DaemonThreadPool
from judo.runtime.address import is_loopback
from judo.runtime.loops import AppLoops

logger = logging.getLogger("judo.app")

IDLE_THREAD_JOIN = 0.1
"""Seconds a stop waits for the planning thread to end before leaving it to finish on its own."""
PLANT_THREAD_JOIN = 1.0
"""Seconds a stop waits for the plant thread to halt the plant and end; a driver blocked longer is left."""


class AppEventLoop(AppLoops):
    """Starts, runs and stops the App's loops (the App's base class; see `judo.runtime.app.App`)."""

    gui_enabled: bool
    host: str
    port: int
    token: str | None
    share: bool
    _loop: asyncio.AbstractEventLoop | None
    _start_error: BaseException | None
    _ready: threading.Event
    _finished: threading.Event
    _running_loops: bool

    async def _main(self, handle_signals: bool = False) -> None:
        loop = asyncio.get_running_loop()
        self._stopping = loop.create_future()
        self._loop = loop
        if self._stop.is_set():  # stop() came before the loop existed
            self._stopping.set_result(None)
        if handle_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, self._request_stop)
        self._executor = DaemonThreadPool(1, "judo-plan")
        try:
            if self.gui_enabled:
                from judo.runtime.gui import Gui  # viser is only imported when a GUI is wanted

                # viser moves to the next free port if this one is taken; raises GuiStartError if it cannot start
                self.gui = Gui(self, self.host, self.port, token=self.token, share=self.share)
                self._warn_if_exposed()
                logger.info("GUI at %s", self.gui.url)
            self._plant_thread = threading.Thread(target=self._drive_plant, name="judo-plant", daemon=True)
            self._plant_thread.start()
            loops = [self._controller_loop(), self._watch_plant(self._plant_thread)]
            if self.gui is not None:
                loops.append(self._gui_loop())
            self.report(self._running_message())
            tasks = [asyncio.create_task(coro) for coro in loops]
            self._running_loops = True
            self._ready.set()
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            self._request_stop()  # a loop only returns when asked to stop, or on a bug: end the others
            for result in await asyncio.gather(*tasks, return_exceptions=True):
                if isinstance(result, BaseException):
                    logger.error("a judo loop failed", exc_info=result)
        except BaseException as err:
            if not self._running_loops:  # the GUI did not start: start() raises this once `_ready` is set
                self._start_error = err
            raise
        finally:
            self._stop.set()
            self._ready.set()
            self._end_plant_thread()
            self._finish_recording("the app stopped")
            if self.gui is not None:
                self.gui.close()
            # An idle planning thread ends at once and is joined; a cycle still in flight (a huge batch,
            # a slow reward) is not waited for: it ends in its own daemon thread.
            self._executor.shutdown(wait=True, timeout=IDLE_THREAD_JOIN)
            self._session.close()
            if handle_signals:
                for sig in (signal.SIGINT, signal.SIGTERM):
                    loop.remove_signal_handler(sig)
            self._loop = None
            self._finished.set()

    def _end_plant_thread(self) -> None:
        """Give the plant thread up to PLANT_THREAD_JOIN s to halt the plant and end, then let no System call
        start any more (a driver blocked in a call is left to return on its own daemon thread)."""
        thread = getattr(self, "_plant_thread", None)
        if thread is not None:
            thread.join(PLANT_THREAD_JOIN)
        self._session.closed_loop.calls.close()

    def _warn_if_exposed(self) -> None:
        """Log what a GUI listening beyond loopback exposes."""
        if is_loopback(self.host) or self.gui is None:
            return
        logger.warning(
            "the GUI listens on %s (%s): anyone who can reach port %d of this machine and has the URL with its "
            "token can change every config, switch the task, pause the plant or reset it, a real robot too. "
            "Prefer the default 127.0.0.1 and an SSH tunnel (docs/gui.md).",
            self.host,
            "every network interface" if self.host in ("0.0.0.0", "::") else "reachable from the network",
            self.gui.server.get_port(),
        )

    def _request_stop(self) -> None:
        """Set the stop flag and wake every loop that waits (from any thread)."""
        self._stop.set()
        loop = self._loop
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._wake_on_stop)
            except RuntimeError:  # the loop has already closed
                pass

    def _wake_on_stop(self) -> None:
        if self._stopping is not None and not self._stopping.done():
            self._stopping.set_result(None)

    def _run_in_thread(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as err:  # before the loops started, start() raises it; later, log it
            if err is not self._start_error:
                logger.error("the judo app failed", exc_info=err)
