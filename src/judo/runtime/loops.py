"""The app's coroutines: thin async wrappers around the one closed-loop step (`judo.runtime.closed_loop`).

Three coroutines share one StateBuffer:
- the system loop calls `ClosedLoop.advance` at real-time pace (step k of a stretch is due at wall time
  origin + k * timestep) and publishes each new reading under "system";
- the controller loop calls `ClosedLoop.plan` at `control_freq` from the latest reading, on a worker thread
  (`run_in_executor`) so the event loop never blocks on rollouts, and publishes the plan, rewards, traces
  and timing under "plan";
- the GUI loop draws state, traces and plots at about 30 Hz.
Commands from other threads (`judo.runtime.app.App`) only queue requests; the loops pick them up at the top
of their next iteration. `AppLoops` is the App's base class: it holds the loops and the state they share.
"""

import asyncio
import functools
import logging
import math
import threading
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from judo.core.config import Config
from judo.core.controller import PlanningCancelled
from judo.core.errors import JudoError
from judo.core.registry import ConfigKind
from judo.core.workers import DaemonThreadPool
from judo.runtime.session import Session, build_session
from judo.runtime.snapshots import PlanSnapshot, SystemSnapshot
from judo.runtime.state_buffer import StateBuffer
from judo.runtime.stats import RunStats
from judo.runtime.status_line import StatusLine
from judo.runtime.system import SimulationDiverged, System, SystemState

if TYPE_CHECKING:
    from judo.runtime.gui import Gui

logger = logging.getLogger("judo.app")

MAX_CATCH_UP = 0.1
"""Most seconds of sim time the system loop steps at once to catch up; beyond that it falls behind."""
IDLE_POLL = 0.01
"""Seconds a loop sleeps while paused or waiting for its first input."""
GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
CONFIG_POLL = 0.25
"""Most seconds the controller loop waits before looking at control_freq again (an edit takes effect)."""


class Stopping(Exception):
    """Raised inside the loops when a stop arrives while they wait for the planning thread."""


class AppLoops:
    """The loops of an App and the state they share with its commands (all guarded by `_lock`)."""

    buffer: StateBuffer
    stats: RunStats
    duration: float | None
    gui: "Gui | None"
    _status_line: StatusLine
    _lock: threading.RLock
    _session: Session
    _configs: dict[ConfigKind, Config]
    _pending: dict[ConfigKind, Config]
    _external_edits: int
    _switch_request: tuple[str, str] | None
    _reset_system: bool
    _reset_controller: bool
    _reset_from_user: bool
    _goal_moves: dict[int, tuple[np.ndarray, np.ndarray | None]]  # mocap index -> (pos (3,), quat (4,) or None)
    _resets_done: int
    _paused: bool
    _stop: threading.Event
    _stopping: asyncio.Future | None
    _executor: DaemonThreadPool
    _user_system: System | None
    _seed: int | None
    _num_workers: int | None
    backend: str

    def report(self, message: str, level: Any = "info") -> None:
        self._status_line.report(message, level)

    def _request_stop(self) -> None:  # judo.runtime.event_loop's
        raise NotImplementedError

    def _running_message(self) -> str:
        session = self._session
        return f"running {session.task_name} with {session.optimizer_name}"

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

    # ---- the system loop: the plant at real-time pace -------------------------------------------------
    async def _system_loop(self) -> None:
        """Step the plant at real-time pace: step k of a stretch is due at wall time origin + k * timestep."""
        generation = -1
        origin = last_wall = 0.0
        steps_done = 0
        paced = False
        while not self._stop.is_set():
            session = self._session
            if session.generation != generation:
                generation, paced = session.generation, False
                self._read_and_publish(session)
            if self._carry_out_plant_requests(session):
                paced = False
            if self._paused:
                paced = False
                await self._sleep(IDLE_POLL)
                continue
            now = time.perf_counter()
            if not paced:
                origin, last_wall, steps_done, paced = now, now, 0, True
            dt = session.system.timestep
            due = int((now - origin) / dt) + 1 - steps_done
            max_steps = max(1, round(MAX_CATCH_UP / dt))
            if due > max_steps:  # too far behind to catch up: fall behind instead (the RTF shows it)
                origin += (due - max_steps) * dt
                due = max_steps
            if self.duration is not None:  # never step past the requested duration
                due = min(due, max(0, math.ceil((self.duration - self.stats.sim_time()) / dt - 1e-9)))
            for _ in range(due):
                self._step(session)
            steps_done += due
            self.stats.record_plant(due * dt, now - last_wall)
            last_wall = now
            if due and session.closed_loop.reading is not None:
                self.buffer.publish("system", SystemSnapshot(session.generation, session.closed_loop.reading))
            if self.duration is not None and self.stats.sim_time() >= self.duration - 1e-9:
                self._request_stop()
                break
            await self._sleep(origin + steps_done * dt - time.perf_counter())

    def _carry_out_plant_requests(self, session: Session) -> bool:
        """A reset or goal moves queued for the plant; True if the plant was reset."""
        with self._lock:
            reset, self._reset_system = self._reset_system, False
            moves, self._goal_moves = self._goal_moves, {}
        if reset:
            try:
                session.system.reset()
            except Exception as err:
                self.report(f"system reset failed: {type(err).__name__}: {err}", "error")
            self._read_and_publish(session)
            self._resets_done += 1
            with self._lock:
                from_user, self._reset_from_user = self._reset_from_user, False
            if from_user:
                self.report(f"{session.task_name} reset to its start state; the plan starts afresh")
        plant = session.simulated
        if moves and plant is not None:
            for index, (position, quat) in moves.items():
                plant.task.data.mocap_pos[index] = position
                if quat is not None:
                    plant.task.data.mocap_quat[index] = quat / np.linalg.norm(quat)
            self._read_and_publish(session)
        return reset

    def _step(self, session: Session) -> None:
        try:
            session.closed_loop.advance()
        except SimulationDiverged as err:
            self.report(str(err), "warning")
            with self._lock:
                self._reset_controller = True
        except Exception as err:  # a user's System or task hook failed; keep serving
            self._status_line.failed("system", f"system step failed: {type(err).__name__}: {err}")
        else:
            self._status_line.recovered("system", f"the system steps again: {self._running_message()}")

    def _read_and_publish(self, session: Session) -> None:
        try:
            reading = session.closed_loop.read()
        except Exception as err:
            self.report(f"system read_state failed: {type(err).__name__}: {err}", "error")
            return
        self.buffer.publish("system", SystemSnapshot(session.generation, reading))

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
        if switch is not None and switch != (self._session.task_name, self._session.optimizer_name):
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
        if task == old.task_name:  # new optimizer on the running plant, keeping the tuned configs
            with self._lock:
                controller_config, task_config = self._configs["controller"], self._configs["task"]
            system = old.system
        else:
            controller_config = task_config = None
            system = self._user_system
        make = functools.partial(
            build_session,
            task,
            optimizer,
            old.generation + 1,
            controller_config=controller_config,  # type: ignore[arg-type]
            task_config=task_config,  # type: ignore[arg-type]
            system=system,
            seed=self._seed,
            num_workers=self._num_workers,
            backend=self.backend,
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
        self.buffer.clear("plan")
        self._read_and_publish(new)
        old.close()
        self._status_line.trouble.clear()
        self.report(f"switched to {task} with {optimizer}{' (paused)' if self._paused else ''}")

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
