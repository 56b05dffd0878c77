"""The planner runner: plans for the session in use at control_freq of wall time, and carries out
the switches and config edits the commands queued (the package's docstring tells who runs what)."""

import dataclasses
import math
import time

from judo.core.errors import JudoError
from judo.core.feedback_plan import FeedbackPlan
from judo.core.planner_view import PlannerKind
from judo.core.reading import SystemState
from judo.core.rollouts.backend import PlanningCancelled
from judo.core.rollouts.rollout import DaemonThreadPool
from judo.loop.timing import ControlClock
from judo.runtime.app_state import AppState, PendingConfigs
from judo.runtime.exchange import PlanningCycle, RunStats, StateBuffer, Stopping, cycle_seconds
from judo.runtime.live_recording import Recordings
from judo.runtime.session import Session, SessionMaker
from judo.runtime.snapshots import PlanSnapshot, seconds_text
from judo.runtime.status import Reports

IDLE_POLL = 0.01
"""Seconds the planner sleeps while paused or waiting for its first reading."""
CONFIG_POLL = 0.25
"""Most seconds the planner waits before looking again (an edit of control_freq takes effect)."""
LATE_CYCLE_LOOK = 0.05
"""Seconds between looks at the planning cycle in flight, to show a late one's time."""
IDLE_THREAD_JOIN = 0.1
"""Seconds a stop waits for the planning thread to end before leaving it to finish on its own."""


class PlannerRunner:
    """Plans for the session in use at control_freq of wall time (see the package's docstring).

    Args:
        state: the app's state (the session, the requests, pause, stop).
        maker: builds the session that replaces the running one on a switch.
        buffer: where each plan is published for the GUI.
        stats: the run's figures (plan times, rewards).
        reports: the status line.
        recordings: the recording under way, finished on a switch of task or optimizer.
    """

    def __init__(
        self,
        *,
        state: AppState,
        maker: SessionMaker,
        buffer: StateBuffer,
        stats: RunStats,
        reports: Reports,
        recordings: Recordings,
    ) -> None:
        self._state, self._maker, self._buffer, self._stats = state, maker, buffer, stats
        self._reports, self._recordings = reports, recordings
        self.clock = ControlClock()
        self._executor = DaemonThreadPool(1, "judo-plan")

    async def run(self) -> None:
        """Plan until a stop (the stop signal must be bound to this event loop)."""
        state = self._state
        try:
            while not state.stop.is_set():
                await self._carry_out_requests()
                session = state.session
                # before the reading: a reset in between only makes the plan look stale
                resets = state.resets_done
                reading = session.closed_loop.reading
                period = 1.0 / session.controller.config.control_freq
                now = time.perf_counter()
                if state.paused or reading is None:
                    self.clock.restart(now)  # a plan is due as soon as there is one to make
                    await state.stop.sleep(IDLE_POLL)
                elif not self.clock.due(now, period):
                    await state.stop.sleep(min(self.clock.remaining(now, period), CONFIG_POLL))
                else:
                    await self._plan(session, reading, now, resets, period)
                    self.clock.ticked(now, time.perf_counter() - now, period)
        except Stopping:
            return

    async def show_late_cycles(self) -> None:
        """Count a late planning cycle's seconds on the status line, once a second (logged once per
        cycle), until a stop."""
        # the late cycle and the whole seconds last shown of it
        shown: tuple[object, int] | None = None
        while not self._state.stop.is_set():
            shown = self._show_late_cycle(shown)
            await self._state.stop.sleep(LATE_CYCLE_LOOK)

    def _show_late_cycle(self, shown: tuple[object, int] | None) -> tuple[object, int] | None:
        cycle = self._state.in_flight.cycle
        if cycle is None or not cycle.late() or cycle.is_set():
            return shown
        seconds = int(cycle.elapsed())
        if shown is not None and shown == (cycle, seconds):
            return shown
        size = "" if cycle.size is None else f" ({cycle.size}, est. {seconds_text(cycle.estimate)})"
        message = (
            f"planning: {seconds} s so far{size}; Pause, Reset task or a smaller setting cancels it"
        )
        if shown is None or shown[0] is not cycle:
            self._reports.report(message, "warning")
        else:
            self._reports.progress(message, "warning")
        return cycle, seconds

    def close(self) -> None:
        """End the planning thread: at once when idle; a cycle still in flight (a huge batch, a slow
        reward) is not waited for beyond IDLE_THREAD_JOIN and ends on its own daemon thread."""
        self._executor.shutdown(wait=True, timeout=IDLE_THREAD_JOIN)

    async def _plan(
        self, session: Session, reading: SystemState, start: float, resets: int, period: float
    ) -> None:
        """One planning cycle from `reading`, read after `resets` plant resets, published under
        "plan"; a failed cycle is reported and skipped. The optimizer iterations beyond
        max_opt_iters (iterations_per_second) run only while they fit in the control `period` (s)
        from `start`."""
        controller, reports, state = session.controller, self._reports, self._state
        with state.lock:
            # what the cycle will take up (the planner is their only writer)
            configs = state.configs
            # None: a policy rolls nothing out
            size = session.controller.cycle_size(configs.by_kind)
            estimate = (
                math.nan
                if size is None
                else cycle_seconds(state.step_cost, size, configs.controller)
            )
            cycle = PlanningCycle(state.stop, size, estimate)
            state.in_flight.start(cycle)  # under the lock: a cancel from now on reaches it
        try:
            plan = await state.stop.in_worker(
                self._executor, session.closed_loop.plan, reading, cycle, start + period
            )
        except Stopping:
            raise
        except PlanningCancelled:
            if state.stop.is_set():
                raise Stopping from None
            reports.report(
                f"planning cycle cancelled after {cycle.elapsed():.1f} s: {cycle.reason}; "
                "the plan before stays"
            )
            return
        except JudoError as err:  # ConfigError, a bad reading: skip this cycle
            reports.failed("planner", f"planning cycle skipped: {err}", "warning")
            return
        except Exception as err:  # an exception in the user's reward or hooks
            reports.failed(
                "planner",
                f"planning cycle skipped: {type(err).__name__} in {session.task_name}: {err}",
            )
            return
        finally:
            state.in_flight.start(None)
        if plan is None:  # no finite reward, or non-finite knots: the plan before stays in force
            reports.failed(
                "planner", f"planning cycle skipped: {session.closed_loop.last_failure}", "warning"
            )
            return
        if reports.line.trouble:  # nothing to clear in the steady state
            reports.recovered("planner", "planning works again")
        if isinstance(plan, FeedbackPlan) and plan.feedback_error is not None:
            reports.report(f"plan served without feedback gains: {plan.feedback_error}", "warning")
        plan_time = time.perf_counter() - start
        rewards = controller.rewards
        assert controller.nominal_knots is not None  # set by every completed cycle
        self._stats.record_plan(
            start, plan_time, float(rewards[0]) if len(rewards) else float("nan")
        )
        # the iterations that fitted in the period
        if size is not None and controller.iterations_run > 0:
            # the same size object when all ran: its total is worked out already
            ran = controller.iterations_run
            state.step_cost.record(
                size if ran == size.iterations else dataclasses.replace(size, iterations=ran),
                plan_time,
            )
        if cycle.late():  # the status line counted its time: say it is over
            reports.report(f"planned in {plan_time:.1f} s: {reports.running()}")
        snapshot = PlanSnapshot(
            session.generation,
            reading.time,
            controller.nominal_knots,
            rewards,
            controller.traces,
            plan_time,
            resets,
        )
        self._buffer.publish("plan", snapshot)

    async def _carry_out_requests(self) -> None:
        """Switches, config edits and resets queued since the last look; no cycle is in flight
        here."""
        if not self._state.planner_pending:  # nothing queued: the steady state
            return
        requests = self._state.take_planner_requests()
        old, pending = self._state.session, requests.configs
        names = (old.task_name, old.optimizer_name)
        if requests.switch is not None and (requests.rebuild or requests.switch != names):
            if await self._switch(*requests.switch):
                pending = PendingConfigs()  # the new session took the accepted configs
        session = self._state.session
        controller = session.controller
        if pending.controller is not None:
            controller.config = pending.controller
        # an optimizer config's edit, if one is pending
        edited, optimizer = pending.optimizer, controller.optimizer
        if edited is not None:
            assert controller.kind is PlannerKind.MPC and optimizer, (
                "a session where a policy plans takes no such edit"
            )
            optimizer.config = edited
        # the planner's task owns the task config; the plant reads it from there
        if pending.task is not None:
            controller.task.config = pending.task
        if requests.forget_plans:
            session.closed_loop.forget_plans()

    async def _switch(self, task: str, optimizer: str) -> bool:
        """Replace the session with one of `task` and `optimizer` (built on the worker thread); True
        if it worked."""
        state, old = self._state, self._state.session
        # a recording goes on
        estimator_only = (task, optimizer) == (old.task_name, old.optimizer_name)
        if not estimator_only:
            self._recordings.finish("the task or optimizer was switched")
        with state.lock:
            sensing, configs = state.sensing, state.configs

        def build() -> Session:
            session = self._maker.switched(old, task, optimizer, sensing, configs)
            # the app stopped meanwhile and will not take it: free its threads
            if state.stop.is_set():
                session.close()
            return session

        try:
            new = await state.stop.in_worker(self._executor, build)
        except Stopping:
            raise
        except Exception as err:
            self._reports.report(
                f"could not switch to {task} with {optimizer}: {type(err).__name__}: {err}", "error"
            )
            return False
        with state.lock:
            state.install_session(new)
            if estimator_only:
                self._recordings.move_to(new)
        self._buffer.clear("plan")
        old.close()
        self._reports.line.trouble.clear()
        self.clock.restart(time.perf_counter())
        estimating = f" and the {new.estimator_name} estimator" if new.estimator_name else ""
        paused = " (paused)" if state.paused else ""
        self._reports.report(
            f"switched to {new.task_name} with {new.optimizer_name}{estimating}{paused}"
        )
        return True
