"""The app's coroutines: thin async wrappers around the one closed-loop step (`judo.runtime.closed_loop`).

The plant runs on a thread of its own (`judo.runtime.plant_loop`): it calls `ClosedLoop.advance` at
real-time pace and publishes each new reading under "system" in the StateBuffer. On the event loop:
- the controller loop calls `ClosedLoop.plan` at `control_freq` from the latest reading, on a worker thread
  (`run_in_executor`) so the event loop never blocks on rollouts, and publishes the plan, rewards, traces
  and timing under "plan";
- the plant monitor reports a System call that blocks, and halts the robot where the System can;
- the GUI loop draws state, traces and plots at about 30 Hz.
Commands from other threads (`judo.runtime.app.App`) only queue requests; the loops pick them up at the top
of their next iteration. `AppLoops` is the App's base class: it holds the loops and the state they share.
"""

import asyncio
import functools
import logging
import threading
import time
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from judo.core.config import Config
from judo.core.controller import PlanningCancelled
from judo.core.errors import JudoError
from judo.core.registry import ConfigKind
from judo.core.workers import DaemonThreadPool
from judo.runtime.plant_loop import PlantLoop
from judo.runtime.session import Sensing, Session, build_session
from judo.runtime.snapshots import PlanSnapshot
from judo.runtime.system import System, SystemState
from judo.runtime.watchdog import PausableClock

if TYPE_CHECKING:
    from judo.runtime.gui import Gui

logger = logging.getLogger("judo.app")

IDLE_POLL = 0.01
"""Seconds a loop sleeps while paused or waiting for its first input."""
GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
PLANT_WATCH_PERIOD = 0.05
"""Seconds between the monitor's looks at the plant thread's System call."""
CONFIG_POLL = 0.25
"""Most seconds the controller loop waits before looking at control_freq again (an edit takes effect)."""


class Stopping(Exception):
    """Raised inside the loops when a stop arrives while they wait for the planning thread."""


class AppLoops(PlantLoop):
    """The controller and GUI coroutines of an App, a monitor of the plant thread, and task switches; the
    plant's own loop (`judo.runtime.plant_loop`) runs on a thread of its own."""

    gui: "Gui | None"
    _configs: dict[ConfigKind, Config]
    _pending: dict[ConfigKind, Config]
    _external_edits: int
    _switch_request: tuple[str, str] | None
    _stopping: asyncio.Future | None
    _executor: DaemonThreadPool
    _user_system: System | None
    _clock: PausableClock
    _seed: int | None
    _sensing: Sensing
    _rebuild_requested: bool
    _recording: Any
    _num_workers: int | None
    backend: str
    system_call_limit: float

    def watchdog_clock(self) -> PausableClock | None:
        """The closed loop's clock: wall time (standing still while paused) for a user's System, a robot;
        None, the plant time stepped, for judo's own simulator, which waits for the planner instead."""
        return None if self._user_system is None else self._clock

    async def _sleep(self, seconds: float) -> None:
        """Wait `seconds`, or until a stop is requested, whichever comes first."""
        stopping = self._stopping
        if seconds > 0 and stopping is not None and not stopping.done():
            await asyncio.wait((stopping,), timeout=seconds)
        else:
            await asyncio.sleep(0)

    async def _in_worker(self, fn: Any, *args: Any) -> Any:
        """`fn(*args)` run on the planning thread; raises Stopping if a stop comes first (the call is
        abandoned to its thread, which ends after it)."""
        assert self._stopping is not None
        future = asyncio.get_running_loop().run_in_executor(self._executor, fn, *args)
        await asyncio.wait((future, self._stopping), return_when=asyncio.FIRST_COMPLETED)
        if self._stop.is_set():
            future.cancel()  # drops the result whenever it comes
            raise Stopping
        return future.result()

    # ---- the plant thread's monitor ---------------------------------------------------------------------
    async def _watch_plant(self, plant_thread: threading.Thread) -> None:
        """Report a System call that has blocked longer than `system_call_limit` (once per block) and halt the
        robot where the System offers a halt; report when it returns. Ends on a stop."""
        reported: tuple[str, float] | None = None
        while not self._stop.is_set():
            calls = self._session.closed_loop.calls
            blocked = calls.blocked(self.system_call_limit)
            if blocked is not None and reported is None:
                reported = blocked
                halting = calls.offers_halt()
                self.report(
                    f"system {blocked[0]}() has not returned for {blocked[1]:.1f} s; "
                    + ("halting the robot" if halting else "the watchdog serves the safe action once it returns"),
                    "error",
                )
                if halting:  # on a thread of its own: the driver's halt may block too
                    threading.Thread(target=self._halt_quietly, daemon=True, name="judo-halt").start()
            elif blocked is None and reported is not None:
                reported = None
                self.report(f"the system responds again: {self._running_message()}")
            if not plant_thread.is_alive() and not self._stop.is_set():
                self.report("the plant thread ended unexpectedly; stopping", "error")
                self._request_stop()
            await self._sleep(PLANT_WATCH_PERIOD)

    def _halt_quietly(self) -> None:
        try:
            self._session.closed_loop.calls.halt()
        except Exception as err:
            self.report(f"system halt failed: {type(err).__name__}: {err}", "error")

    def _on_watchdog(self, reason: str | None) -> None:
        """The closed loop's watchdog tripped (`reason`) or recovered (None): say so once per episode."""
        if reason is not None:
            self._status_line.failed("watchdog", f"watchdog: {reason}; serving the safe action", "warning")
        elif "watchdog" in self._status_line.trouble:  # said even when another part's recovery came first
            self._status_line.trouble.discard("watchdog")
            self.report(f"fresh plans are served again: {self._running_message()}")

    # ---- the controller loop: plan at control_freq -----------------------------------------------------
    async def _controller_loop(self) -> None:
        try:
            while not self._stop.is_set():
                await self._apply_controller_requests()
                session = self._session
                snapshot = self.buffer.latest("system")
                if self._paused or snapshot is None or snapshot.value.generation != session.generation:
                    await self._sleep(IDLE_POLL)
                    continue
                start = time.perf_counter()
                await self._plan(session, snapshot.value.reading, start)
                await self._wait_out_period(start)
        except Stopping:
            return

    async def _plan(self, session: Session, reading: SystemState, start: float) -> None:
        """One planning cycle from `reading`, published under "plan"; a failed cycle is reported and skipped."""
        controller, lines = session.controller, self._status_line
        try:
            plan = await self._in_worker(session.closed_loop.plan, reading, self._stop)
        except (PlanningCancelled, Stopping):
            raise Stopping from None
        except JudoError as err:  # ConfigError, a bad reading: skip this cycle
            lines.failed("planner", f"planning cycle skipped: {err}", "warning")
            return
        except Exception as err:  # an exception in the user's reward or hooks
            lines.failed("planner", f"planning cycle skipped: {type(err).__name__} in {session.task_name}: {err}")
            return
        if plan is None:  # no finite reward, or non-finite knots: the plan before stays in force
            lines.failed("planner", f"planning cycle skipped: {session.closed_loop.last_failure}", "warning")
            return
        lines.recovered("planner", f"planning works again: {self._running_message()}")
        plan_time = time.perf_counter() - start
        rewards = controller.rewards
        assert controller.nominal_knots is not None  # set by every completed cycle
        self.stats.record_plan(start, plan_time, float(rewards[0]) if len(rewards) else float("nan"))
        snapshot = PlanSnapshot(
            session.generation, reading.time, controller.nominal_knots, rewards, controller.traces, plan_time
        )
        self.buffer.publish("plan", snapshot)

    async def _wait_out_period(self, start: float) -> None:
        """Wait until one control period after `start`, following edits of control_freq as they come."""
        while not self._stop.is_set():
            period = 1.0 / self._configs["controller"].control_freq  # type: ignore[attr-defined]
            remaining = start + period - time.perf_counter()
            if remaining <= 0:
                return
            await self._sleep(min(remaining, CONFIG_POLL))

    async def _apply_controller_requests(self) -> None:
        """Switches, resets and config edits queued since the last cycle; no cycle is in flight here."""
        with self._lock:
            switch, self._switch_request = self._switch_request, None
            rebuild, self._rebuild_requested = self._rebuild_requested, False
        if switch is not None and (rebuild or switch != (self._session.task_name, self._session.optimizer_name)):
            await self._switch(*switch)
        with self._lock:
            pending, self._pending = self._pending, {}
            reset, self._reset_controller = self._reset_controller, False
        session = self._session
        controller = session.controller
        for kind, config in pending.items():
            if kind == "controller":
                controller.config = config  # type: ignore[assignment]
            elif kind == "optimizer":
                controller.optimizer.config = config
            else:
                controller.task.config = config
                if session.simulated is not None:
                    session.simulated.task.config = config
        if reset:
            session.closed_loop.forget_plans()

    async def _switch(self, task: str, optimizer: str) -> None:
        old = self._session
        estimator_only = (task, optimizer) == (old.task_name, old.optimizer_name)  # a recording goes on
        if not estimator_only:
            self._finish_recording("the task or optimizer was switched")
        optimizer_config = None
        if task == old.task_name:  # new optimizer on the running plant, keeping the tuned configs
            with self._lock:
                controller_config, task_config = self._configs["controller"], self._configs["task"]
                if estimator_only:
                    optimizer_config = self._configs["optimizer"]
            system = old.system
            estimator = old.closed_loop.estimator  # its live config goes on with the running plant, unless replaced
            keep = estimator is not None and self._sensing.estimator in (None, old.estimator_name)
            sensing = replace(self._sensing, estimator_config=estimator.config) if keep else self._sensing  # type: ignore[union-attr]
        else:
            controller_config = task_config = None
            system = self._user_system
            sensing = self._sensing
        make = functools.partial(
            build_session,
            task,
            optimizer,
            old.generation + 1,
            controller_config=controller_config,  # type: ignore[arg-type]
            optimizer_config=optimizer_config,  # type: ignore[arg-type]
            task_config=task_config,  # type: ignore[arg-type]
            system=system,
            seed=self._seed,
            num_workers=self._num_workers,
            backend=self.backend,
            clock=self.watchdog_clock(),
            on_watchdog=self._on_watchdog,
            sensing=sensing,
            reading=old.closed_loop.raw_reading if system is old.system else None,  # its thread is reading it
            estimator_thread=True,
        )

        def build() -> Session:
            session = make()
            if self._stop.is_set():  # the app stopped meanwhile and will not take it: free its threads
                session.close()
            return session

        try:
            new = await self._in_worker(build)
        except Stopping:
            raise
        except Exception as err:
            self.report(f"could not switch to {task} with {optimizer}: {type(err).__name__}: {err}", "error")
            return
        with self._lock:
            self._session = new
            self._configs = session_configs(new)
            self._pending = {}
            self._external_edits += 1
            if estimator_only and self._recording is not None:
                self._recording.move_to(new)
        self.buffer.clear("plan")
        self._read_and_publish(new)
        old.close()
        self._status_line.trouble.clear()
        estimating = f" and the {new.estimator_name} estimator" if new.estimator_name else ""
        self.report(f"switched to {task} with {optimizer}{estimating}{' (paused)' if self._paused else ''}")

    def _finish_recording(self, why: str) -> None:
        """Write the recording under way, if any (on a switch or a stop), reporting a failure."""
        if getattr(self, "_recording", None) is None:
            return
        try:
            self.stop_recording()  # type: ignore[attr-defined]  (AppCommands')
        except Exception as err:
            self.report(f"the recording ({why}) could not be written: {type(err).__name__}: {err}", "error")

    # ---- the GUI loop ------------------------------------------------------------------------------------
    async def _gui_loop(self) -> None:
        while not self._stop.is_set():
            start = time.perf_counter()
            try:
                assert self.gui is not None
                self.gui.update()
            except Exception as err:
                self.report(f"GUI update failed: {type(err).__name__}: {err}", "error")
            await self._sleep(start + GUI_PERIOD - time.perf_counter())


def session_configs(session: Session) -> dict[ConfigKind, Config]:
    """The configs a session's controller uses, by kind."""
    controller = session.controller
    return {"controller": controller.config, "optimizer": controller.optimizer.config, "task": controller.task.config}
