"""The app's plant loop: the System driven from one thread of its own, at real-time pace.

judo's own simulator waits for a slow planner (`sim_waits`): on a slow machine the simulation slows down
and the real-time factor shows it.
A user's System (a robot) is never held back.

Step k of a stretch is due at wall time origin + k * timestep; a loop that falls further behind than
MAX_CATCH_UP steps at once falls behind instead (the real-time factor shows it). Each step is the closed
loop's `advance` (`judo.runtime.closed_loop`): serve, apply, step, read back. Off the event loop, a driver
that blocks freezes neither the GUI nor planning; the event loop's monitor (`AppLoops._watch_plant`)
reports a call that blocks and halts the robot where the System can. The plant is halted on a pause and
on the way out of a stop.
"""

import logging
import math
import threading
import time
from typing import Any

import numpy as np

from judo.runtime.closed_loop import ClosedLoop, SystemCallError
from judo.runtime.session import Session
from judo.runtime.snapshots import SystemSnapshot
from judo.runtime.state_buffer import StateBuffer
from judo.runtime.stats import RunStats
from judo.runtime.status_line import StatusLine
from judo.runtime.system import SimulationDiverged, SystemState
from judo.runtime.system_calls import SystemClosedError

logger = logging.getLogger("judo.app")

MAX_CATCH_UP = 0.1
"""Most seconds of sim time the plant loop steps at once to catch up; beyond that it falls behind."""
IDLE_POLL = 0.01
"""Seconds the plant loop sleeps while paused."""
WAIT_REPORT = 2.0
"""Wall seconds the simulation waits for one planning cycle before the status line says so."""


def sim_waits(loop: ClosedLoop) -> bool:
    """Whether judo's own simulator waits before its next step (docs/gui.md; a robot never does): while the
    planning cycle in flight would take more than one control period of sim time, and between cycles while the
    plan in force would age past max(2 periods, max_plan_age / 2) (a planner thread late to start its next
    cycle); never after a failed cycle, so a failing planner still trips the watchdog."""
    config = loop.controller.config
    period, next_time = 1.0 / config.control_freq, loop.stepped_time + loop.system.timestep
    started = loop.cycle_started
    if started is not None:
        return next_time - started > period + 1e-9
    newest = max(loop.plan_stamp, loop.newest_stamp)  # a finished plan is in force from the next step on
    return not loop.last_cycle_failed and next_time - newest > max(2 * period, config.max_plan_age / 2)


def system_snapshot(session: Session, reading: SystemState) -> SystemSnapshot:
    """The "system" snapshot of `reading`, with the simulated plant's true state when an estimator runs."""
    plant = session.simulated
    truth = plant.plant_state() if plant is not None and session.closed_loop.estimator is not None else None
    return SystemSnapshot(session.generation, reading, truth)


class PlantLoop:
    """The plant thread of an App and the state it shares with the App's commands (guarded by `_lock`)."""

    buffer: StateBuffer
    stats: RunStats
    duration: float | None
    _status_line: StatusLine
    _lock: threading.RLock
    _session: Session
    _reset_system: bool
    _reset_controller: bool
    _reset_from_user: bool
    _goal_moves: dict[int, tuple[np.ndarray, np.ndarray | None]]  # mocap index -> (pos (3,), quat (4,) or None)
    _resets_done: int
    _paused: bool
    _stop: threading.Event
    _waiting_since: float | None = None  # wall time the simulation began to wait for the cycle in flight
    _wait_reported = False

    def report(self, message: str, level: Any = "info") -> None:
        self._status_line.report(message, level)

    def _request_stop(self) -> None:  # judo.runtime.event_loop's
        raise NotImplementedError

    def _running_message(self) -> str:
        session = self._session
        return f"running {session.task_name} with {session.optimizer_name}"

    def _drive_plant(self) -> None:
        """The plant thread: step the plant at real-time pace until a stop; halt it on a pause and at the end."""
        generation = -1
        origin = last_wall = 0.0
        steps_done = 0
        paced = halted = False
        session = self._session
        try:
            while not self._stop.is_set():
                session = self._session
                if session.generation != generation:
                    generation, paced = session.generation, False
                    self._read_and_publish(session)
                if self._carry_out_plant_requests(session):
                    paced = False
                if self._paused:
                    if not halted:
                        halted = self._halt(session, "paused")
                    paced = False
                    self._stop.wait(IDLE_POLL)
                    continue
                halted = False
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
                waits = not session.closed_loop.real_time  # judo's own simulator waits for a slow planner
                served = stepped = 0
                while stepped < due and not self._stop.is_set():
                    if waits and sim_waits(session.closed_loop):
                        break
                    served += self._step(session)
                    stepped += 1
                steps_done += stepped
                if stepped < due:  # waiting for the planner: resume pacing from when it is done
                    paced = False
                    self._note_wait(True)
                elif stepped:
                    self._note_wait(False)
                self.stats.record_plant(served * dt, now - last_wall)  # only the ticks the plant got
                last_wall = now
                if stepped and session.closed_loop.reading is not None:
                    self.buffer.publish("system", system_snapshot(session, session.closed_loop.reading))
                if self.duration is not None and self.stats.sim_time() >= self.duration - 1e-9:
                    self._request_stop()
                    break
                wait = IDLE_POLL / 10 if not paced else max(0.0, origin + steps_done * dt - time.perf_counter())
                self._stop.wait(wait)
            self._halt(session, "stopped")
        except SystemClosedError:  # the app stopped while a call was blocked: no further call
            return

    def _note_wait(self, waiting: bool) -> None:
        """Say once when the simulator has waited WAIT_REPORT s for one planning cycle, and when it goes on."""
        now = time.perf_counter()
        if not waiting:
            if self._wait_reported:
                self.report(f"the planner caught up; the simulation goes on: {self._running_message()}")
            self._waiting_since, self._wait_reported = None, False
            return
        if self._waiting_since is None:
            self._waiting_since = now
        elif not self._wait_reported and now - self._waiting_since > WAIT_REPORT:
            self._wait_reported = True
            self.report(
                f"the simulation has waited {now - self._waiting_since:.1f} s for a planning cycle "
                "(it waits rather than let a cycle take more than one control period of sim time)",
                "warning",
            )

    def _halt(self, session: Session, why: str) -> bool:
        """Bring the plant to rest (the System's halt, or the safe action); True if it worked."""
        try:
            session.closed_loop.halt()
        except SystemClosedError:
            raise
        except Exception as err:
            self.report(f"system halt ({why}) failed: {type(err).__name__}: {err}", "error")
            return False
        return True

    def _carry_out_plant_requests(self, session: Session) -> bool:
        """A reset or goal moves queued for the plant; True if the plant was reset."""
        with self._lock:
            reset, self._reset_system = self._reset_system, False
            moves, self._goal_moves = self._goal_moves, {}
            from_user = reset and self._reset_from_user
            if reset:
                self._reset_from_user = False
        if reset:
            try:
                reading = session.closed_loop.reset_plant()
            except SystemClosedError:
                raise
            except Exception as err:  # the plan is not restarted as if the reset had worked
                self.report(f"system reset failed: {type(err).__name__}: {err}; the plan was kept", "error")
            else:
                self.buffer.publish("system", system_snapshot(session, reading))
                self._resets_done += 1
                with self._lock:
                    self._reset_controller = True
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

    def _step(self, session: Session) -> bool:
        """One plant step; True if the plant got its action and its step."""
        try:
            session.closed_loop.advance()
        except SimulationDiverged as err:
            self.report(str(err), "warning")
            with self._lock:
                self._reset_controller = True
            return True
        except SystemCallError as err:  # a user's System or task hook failed; keep serving
            self._status_line.failed("system", str(err))
            return err.served
        except SystemClosedError:
            raise
        except Exception as err:
            self._status_line.failed("system", f"system step failed: {type(err).__name__}: {err}")
            return False
        self._status_line.recovered("system", f"the system steps again: {self._running_message()}")
        return True

    def _read_and_publish(self, session: Session) -> None:
        try:
            reading = session.closed_loop.read()
        except SystemClosedError:
            raise
        except Exception as err:
            self.report(f"system read_state failed: {type(err).__name__}: {err}", "error")
            return
        self.buffer.publish("system", system_snapshot(session, reading))
