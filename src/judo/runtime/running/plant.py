"""The plant runner: the System driven from one thread of its own at real-time pace (the package's
docstring tells who runs what)."""

import logging
import math
import threading
import time
from collections.abc import Callable

from judo.core.reading import SystemState
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import SimulationDiverged, SystemCallError, SystemClosedError
from judo.loop.timing import PlantClock
from judo.runtime.app_state import AppState
from judo.runtime.exchange import RunStats, StateBuffer
from judo.runtime.session import Session
from judo.runtime.snapshots import SystemSnapshot
from judo.runtime.status import Reports

logger = logging.getLogger("judo.app")

IDLE_POLL = 0.01
"""Seconds the plant loop sleeps while paused."""
PLANT_WATCH_PERIOD = 0.05
"""Seconds between the event loop's looks at the plant thread's System call."""
WAIT_REPORT = 2.0
"""Wall seconds the simulation waits for one planning cycle before the status line says so."""


def sim_waits(loop: ClosedLoop) -> bool:
    """Whether judo's own simulator waits before its next step (docs/gui.md; a robot never does):
    while the planning cycle in flight would take more than one control period of sim time, and
    between cycles while the plan in force would age past max(2 periods, max_plan_age / 2) (a
    planner thread late to start its next cycle); never after a failed cycle, so a failing planner
    still trips the watchdog."""
    config = loop.controller.config
    period, next_time = 1.0 / config.control_freq, loop.stepped_time + loop.system.timestep
    started = loop.cycle_started
    if started is not None:
        return next_time - started > period + 1e-9
    # a finished plan is in force from the next step on
    newest = max(loop.plans.stamp, loop.newest_stamp)
    return not loop.last_cycle_failed and next_time - newest > max(
        2 * period, config.max_plan_age / 2
    )


def system_snapshot(session: Session, reading: SystemState) -> SystemSnapshot:
    """The "system" snapshot of `reading`, with the simulated plant's true state when an estimator
    runs."""
    plant = session.simulated
    truth = (
        plant.plant_state()
        if plant is not None and session.closed_loop.estimator is not None
        else None
    )
    return SystemSnapshot(session.generation, reading, truth)


class PlantRunner:
    """The plant thread of an App: steps the session's plant at real-time pace, carries out the
    plant's requests (resets, goal moves) and publishes each new reading under "system" for the GUI.

    Args:
        state: the app's shared state (the session in use, pause, the plant's requests).
        buffer: where the readings are published for the GUI.
        stats: the run's figures (sim time stepped, real-time factor).
        reports: the status line.
        duration: stop after this many seconds of sim time (None: run until stopped).
        request_stop: called when `duration` is reached.
    """

    def __init__(
        self,
        *,
        state: AppState,
        buffer: StateBuffer,
        stats: RunStats,
        reports: Reports,
        duration: float | None,
        request_stop: Callable[[], None],
    ) -> None:
        self._state, self._buffer, self._stats, self._reports = state, buffer, stats, reports
        self._duration, self._request_stop = duration, request_stop
        # wall time the simulation began to wait for the cycle in flight
        self._waiting_since: float | None = None
        self._wait_reported = False
        self.thread = threading.Thread(target=self._drive_plant, name="judo-plant", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _drive_plant(self) -> None:
        """The plant thread: step the plant at real-time pace until a stop; halt it on a pause and
        at the end."""
        generation = -1
        last_wall = time.perf_counter()
        clock, halted = PlantClock(), False
        session = self._state.session
        try:
            while not self._state.stop.is_set():
                session = self._state.session
                if session.generation != generation:
                    generation = session.generation
                    clock.restart()
                    self._read_and_publish(session)
                if self._carry_out_plant_requests(session):
                    clock.restart()
                if self._state.paused:
                    if not halted:
                        halted = self._halt(session, "paused")
                    clock.restart()
                    self._state.stop.wait(IDLE_POLL)
                    last_wall = time.perf_counter()  # paused time is not run time
                    continue
                halted = False
                now = time.perf_counter()
                dt = session.system.timestep
                # a wait for the planner stays in the run's wall time: the RTF shows it
                due = clock.due(now, dt)
                if self._duration is not None:  # never step past the requested duration
                    due = min(
                        due,
                        max(0, math.ceil((self._duration - self._stats.sim_time()) / dt - 1e-9)),
                    )
                # judo's own simulator waits for a slow planner
                waits = not session.closed_loop.real_time
                served = stepped = 0
                while stepped < due and not self._state.stop.is_set():
                    if waits and sim_waits(session.closed_loop):
                        break
                    served += self._step(session)
                    stepped += 1
                clock.stepped(stepped)
                if stepped < due:  # waiting for the planner: resume pacing from when it is done
                    clock.restart()
                    self._note_wait(True)
                elif stepped:
                    self._note_wait(False)
                # only the ticks the plant got
                self._stats.record_plant(served * dt, now - last_wall)
                last_wall = now
                if stepped and session.closed_loop.reading is not None:
                    self._buffer.publish(
                        "system", system_snapshot(session, session.closed_loop.reading)
                    )
                if self._duration is not None and self._stats.sim_time() >= self._duration - 1e-9:
                    self._request_stop()
                    break
                wait = clock.wait(time.perf_counter(), dt) if clock.running else IDLE_POLL / 10
                self._state.stop.wait(wait)
            self._halt(session, "stopped")
        except SystemClosedError:  # the app stopped while a call was blocked: no further call
            return

    def _note_wait(self, waiting: bool) -> None:
        """Say once when the simulator has waited WAIT_REPORT s for one planning cycle, and when it
        goes on."""
        now = time.perf_counter()
        if not waiting:
            if self._wait_reported:
                self._reports.report(
                    f"the planner caught up; the simulation goes on: {self._reports.running()}"
                )
            self._waiting_since, self._wait_reported = None, False
            return
        if self._waiting_since is None:
            self._waiting_since = now
        elif not self._wait_reported and now - self._waiting_since > WAIT_REPORT:
            self._wait_reported = True
            self._reports.report(
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
            self._reports.report(
                f"system halt ({why}) failed: {type(err).__name__}: {err}", "error"
            )
            return False
        return True

    def _carry_out_plant_requests(self, session: Session) -> bool:
        """Take up the task config in force, then a reset or goal moves queued for the plant; True
        if the plant was reset. The planner's task owns the task config: the simulated plant's task
        reads it here, on its own thread."""
        if (simulated := session.simulated) is not None:
            simulated.task.config = session.controller.task.config
        if not self._state.plant_pending:  # nothing queued: the steady state
            return False
        requests = self._state.take_plant_requests()
        reset, moves = requests.reset, requests.goal_moves
        if reset:
            try:
                reading = session.closed_loop.reset_plant()
            except SystemClosedError:
                raise
            except Exception as err:  # the plan is not restarted as if the reset had worked
                self._reports.report(
                    f"system reset failed: {type(err).__name__}: {err}; the plan was kept", "error"
                )
            else:
                self._buffer.publish("system", system_snapshot(session, reading))
                self._state.note_plant_reset()
                if requests.reset_from_user:
                    self._reports.report(
                        f"{session.task_name} reset to its start state; the plan starts afresh"
                    )
        # the System whose goals they are
        plant = session.system if simulated is None else simulated
        if moves:
            try:
                for index, (position, quat) in moves.items():
                    plant.move_goal(index, position, quat)
            except SystemClosedError:
                raise
            except Exception as err:
                self._reports.report(f"goal not moved: {type(err).__name__}: {err}", "warning")
            self._read_and_publish(session)
        return reset

    def _step(self, session: Session) -> bool:
        """One plant step; True if the plant got its action and its step."""
        try:
            session.closed_loop.advance()
        except SimulationDiverged as err:
            self._reports.report(str(err), "warning")
            self._state.note_divergence()
            return True
        except SystemCallError as err:  # a user's System or task hook failed; keep serving
            self._reports.failed("system", str(err))
            return err.served
        except SystemClosedError:
            raise
        except Exception as err:
            self._reports.failed("system", f"system step failed: {type(err).__name__}: {err}")
            return False
        if self._reports.line.trouble:  # nothing to clear in the steady state
            self._reports.recovered("system", "the system steps again")
        return True

    def _read_and_publish(self, session: Session) -> None:
        try:
            reading = session.closed_loop.read()
        except SystemClosedError:
            raise
        except Exception as err:
            self._reports.report(f"system read_state failed: {type(err).__name__}: {err}", "error")
            return
        self._buffer.publish("system", system_snapshot(session, reading))

    async def watch(self, system_call_limit: float) -> None:
        """On the event loop: report a call into a user's System that has blocked longer than
        `system_call_limit` s (once per block) and halt the robot where the System offers a halt;
        report when it returns; stop the app if the plant thread died. Ends on a stop."""
        state, reports = self._state, self._reports
        reported: tuple[str, float] | None = None
        while not state.stop.is_set():
            session = state.session
            calls = session.closed_loop.calls
            # judo's own simulator never hangs in a call: a late step there is this process busy
            # elsewhere (a page that connects is sent the whole scene), not a driver to halt
            blocked = None if session.simulated is not None else calls.blocked(system_call_limit)
            if blocked is not None and reported is None:
                reported = blocked
                halting = calls.offers_halt()
                reports.report(
                    f"system {blocked[0]}() has not returned for {blocked[1]:.1f} s; "
                    + (
                        "halting the robot"
                        if halting
                        else "the watchdog serves the safe action once it returns"
                    ),
                    "error",
                )
                if halting:  # on a thread of its own: the driver's halt may block too
                    threading.Thread(
                        target=self._halt_quietly, daemon=True, name="judo-halt"
                    ).start()
            elif blocked is None and reported is not None:
                reported = None
                reports.report(f"the system responds again: {reports.running()}")
            if not self.thread.is_alive() and not state.stop.is_set():
                reports.report("the plant thread ended unexpectedly; stopping", "error")
                state.stop.set()
            await state.stop.sleep(PLANT_WATCH_PERIOD)

    def _halt_quietly(self) -> None:
        try:
            self._state.session.closed_loop.calls.halt()
        except Exception as err:
            self._reports.report(f"system halt failed: {type(err).__name__}: {err}", "error")
