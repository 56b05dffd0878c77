"""The one closed-loop step: read the plant, plan (with the latency model), serve the plan, step the
plant.

Everything that drives a plant with a controller calls this module, and nothing else writes the
loop: the app's planner runner calls `plan` on its worker thread and its plant runner `advance` at
real-time pace; `evaluate`'s episodes (and `tune`'s trials) call `step`, which plans when the
control clock (`ControlClock`) says, in sim time, then advances; the benchmark times `plan`.

    reading = system.read_state()  --[estimator]-->  plan(reading)  --latency-->  serve(t)  --[watchdog]-->
    system.apply(action); system.step()  -->  read back  --[recorders: on_plan, on_step]

Where the features plug in, each once, here:
- the estimator (`judo.loop.estimation`): `read` fuses the System's raw reading into the state
  planned from, as of the plant's now;
- the latency model and the watchdog (`judo.loop.timing`): a plan from the reading at time t is
  served from plant time t + delay (sim seconds, or "measured": the update's wall time; the app
  uses 0); `serve` gives the task's `safe_action` instead of a plan older than
  `ControllerConfig.max_plan_age` beyond one control period (`on_watchdog` is told why);
- recorders of every step and plan (`judo.loop.records.Recorder`);
- the guard on every served action (`judo.loop.guard.Guard`: `judo.safety_guard`) and the latched
  stop (`judo.loop.guard.Stop`): while it is engaged, `serve` gives the safe action and `advance`
  holds the plant by the System's halt where it offers one.
"""  # noqa: E501

import collections
import math
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from judo.core.errors import JudoError, NonFiniteKnotsError, NonFiniteRewardError
from judo.core.estimator import Estimator
from judo.core.planner import Planner
from judo.core.reading import SystemState
from judo.core.spline import Spline
from judo.loop.estimation import Estimation
from judo.loop.guard import Guard, Stop
from judo.loop.records import PlanRecord, Recorder, StepRecord
from judo.loop.system import (
    SimulationDiverged,
    System,
    SystemCallError,
    SystemCalls,
    SystemClosedError,
)
from judo.loop.timing import (
    RECENT_CYCLES,
    ControlClock,
    Latency,
    LatencyPredictor,
    PlanQueue,
    Watchdog,
    check_latency,
    prediction_delay,
    safe_action,
)

__all__ = ["ClosedLoop"]


class ClosedLoop:
    """A controller driving a plant: read, plan, serve, step.

    Args:
        controller: a Planner (a Controller or a PolicyController); it never reads the plant's data.
        system: the plant (a simulator, rehearsed sensing or hardware).
        latency: seconds of sim time between a plan's reading and its being served, or "measured".
        recorders: objects with `on_plan(PlanRecord)` and `on_step(StepRecord)`, called in order.
        clock: the watchdog's clock in seconds; None counts the plant time the loop has stepped
            (evaluate, tune), the app passes the wall clock.
        on_watchdog: called with the reason whenever the watchdog has news (`judo.loop.timing`:
            what is told and when), with None when a fresh plan is served again.
        estimator: turns each raw reading into the state planned from (None: plan from the reading's
            state), fed every served action (`judo.loop.estimation`).
        keep_updates: keep at least the latest this many entries of `update_ms` and `latency_s` (at
            most twice as many), for a loop that runs for days (the app); None keeps every update's
            (an episode's log).
        stop: the latched stop (a `judo.loop.guard.Stop`, as `judo.safety.stop.StopLatch`): while it
            is engaged the plant is served the safe action, or held by the System's own `halt()`
            (called once per latch, then nothing is applied) where it offers one.
        guard: each served action passes its `filter` (a `judo.loop.guard.Guard`: the owner's
            limits, built with `judo.safety_guard(controller, SafetyConfig(...))`, which also
            screens a Controller's rollouts); None: none.

    Attributes:
        reading: the latest reading of the plant (None until the first `read`).
        update_ms: wall times of every control update (the latest `keep_updates`), in milliseconds
            (failed ones too).
        latency_s: the delay after which each update's plan took effect, in seconds (as many).
        failed_updates: updates whose rollouts all scored NaN or -inf, or whose knots were
            non-finite (the plan before stayed in force); `last_failure`: the latest one's error.
        divergences: times the plant's simulation blew up and was reset.
        control_clock: when `step` makes the next control update, in plant time.

    `plan` may run on another thread than `serve` and `advance` (the app's worker thread): the
    hand-over of a new plan is locked (`judo.loop.timing.PlanQueue`).
    """

    def __init__(
        self,
        controller: Planner,
        system: System,
        *,
        latency: Latency = 0.0,
        recorders: Iterable[Recorder] = (),
        clock: Callable[[], float] | None = None,
        on_watchdog: Callable[[str | None], None] | None = None,
        estimator: Estimator | None = None,
        keep_updates: int | None = None,
        guard: Guard | None = None,
        stop: Stop | None = None,
    ) -> None:
        check_latency(latency)
        self.controller, self.system, self.latency = controller, system, latency
        self.calls = SystemCalls(system)  # every System call goes through it (see judo.loop.system)
        self.recorders = [*recorders, *filter(None, [system.recorder()])]  # and the System's log
        self.estimator = estimator
        self.estimation = Estimation(system, controller.task, estimator)
        self.raw_reading: SystemState | None = None  # the System's latest, before the estimator
        self.reading: SystemState | None = None
        self.stepped_time = 0.0  # plant time this loop has stepped: the default clock
        self.clock = clock if clock is not None else (lambda: self.stepped_time)
        self.real_time = clock is not None  # the app's wall clock
        self.on_watchdog, self.watchdog = on_watchdog, Watchdog()
        self.watchdog.restart(self.clock())
        self.plans = PlanQueue(self.clock())  # the plans waiting for their time, the one in force
        self._safe_state: np.ndarray | None = None  # (nq + nv,) the latest finite reading
        self.update_ms: list[float] = []
        self.latency_s: list[float] = []
        self.keep_updates = keep_updates
        # the latched stop, whether the System's halt holds the plant, the owner's limits
        self.stop, self._stop_halted, self.guard = stop, False, guard
        self.failed_updates, self.divergences, self.last_delay = 0, 0, 0.0
        self.control_clock, self._predictor = ControlClock(), LatencyPredictor(controller.task)
        self.last_failure: JudoError | None = None  # why the latest failed update failed
        self.cycle_started: float | None = None  # stepped_time when the cycle in flight began
        # whether the last cycle failed, and the newest scheduled plan's stamp
        self.last_cycle_failed, self.newest_stamp = False, self.plans.stamp
        self.last_cycle_plant_time = 0.0  # plant time stepped (by another thread) in the last cycle
        # plant time from each recent cycle's reading to the newest reading when it ended
        self.cycle_plant_times: collections.deque[float] = collections.deque(maxlen=RECENT_CYCLES)

    def forget_plans(self) -> None:
        """Forget every plan, the controller's too: the plant gets the warm start until the next
        plan."""
        self.controller.reset()
        self.plans.forget(self.clock())  # the warm start counts as a plan from now

    def restart(self) -> SystemState:
        """Forget every plan and read the plant; the control clock starts at the reading's time.
        Call it after the plant was reset, whose time may start again."""
        self.forget_plans()
        self.watchdog.restart(self.clock())
        self.estimation.restart()
        reading = self.read()
        self.control_clock.restart(reading.time)
        return reading

    def read(self) -> SystemState:
        """Read the plant: the reading the next plan starts from, kept as `reading`. Raises
        ReadingTimeError, keeping the reading before, if its time went backwards."""
        raw = self.calls.read_state()
        self.watchdog.note_reading(raw, self.clock())
        self.raw_reading = raw
        reading = raw if self.estimator is None else self.estimation.estimate(raw)
        self.reading = reading
        state, model = reading.state, self.controller.task.model
        if state is not None and np.shape(state) == (model.nq + model.nv,):
            if np.isfinite(state).all():
                self._safe_state = np.array(state, dtype=float)
        return reading

    def plan(
        self,
        reading: SystemState,
        cancel: threading.Event | None = None,
        deadline: float | None = None,
    ) -> Spline | None:
        """One control update from `reading`, scheduled to be served after the latency model's
        delay. A `deadline` (a time.perf_counter() value) ends the optimizer iterations beyond
        `max_opt_iters` that would end after it.

        Returns the new plan, or None when the update failed on non-finite rewards or knots (counted
        in `failed_updates`; the plan before stays in force). Other errors (a reward that raises, an
        invalid config, a set `cancel`) propagate, with nothing scheduled."""
        stamp = self.watchdog.fresh_at
        started = time.perf_counter()
        stepped = self.cycle_started = self.stepped_time
        self.last_cycle_failed = True
        try:
            start = self._predicted(reading) if self.predicts() else reading
            plan = self.controller.update_action(
                start.state, start.time, start.metadata, cancel, deadline
            )
        except (NonFiniteRewardError, NonFiniteKnotsError) as err:
            plan, self.last_failure = None, err
            self.failed_updates += 1
        finally:
            self.cycle_started = None
            self.last_cycle_plant_time = self.stepped_time - stepped
            latest = self.reading  # the plant thread's newest: the plan is served from its time on
            self.cycle_plant_times.append(
                0.0 if latest is None else max(0.0, latest.time - reading.time)
            )
        wall = time.perf_counter() - started
        delay = wall if self.latency == "measured" else float(self.latency)
        # a plan made for a predicted reading takes effect no earlier than that reading's time
        if plan is not None:
            delay = max(delay, start.time - reading.time)
        self.update_ms.append(1e3 * wall)
        self.latency_s.append(delay)
        if self.keep_updates is not None and len(self.update_ms) > 2 * self.keep_updates:
            # amortised O(1)
            del self.update_ms[: -self.keep_updates], self.latency_s[: -self.keep_updates]
        self.last_delay = delay
        if plan is None:
            return None
        self.last_cycle_failed, self.newest_stamp = False, stamp
        self.plans.schedule(reading.time + delay, plan, stamp)
        if self.recorders:  # the record is built only for someone to read it
            wanted = any(getattr(recorder, "wants_traces", False) for recorder in self.recorders)
            traces = plan.traces.astype(np.float32) if wanted else None  # a copy, to keep
            record = PlanRecord.of_update(
                reading.time, delay, plan.knots, wall, plan.rewards, traces
            )
            for recorder in self.recorders:
                recorder.on_plan(record)
        return plan

    def predicts(self) -> bool:
        """Whether a plan is made from the reading predicted to when it takes effect: with latency
        compensation, and with feedback gains (a planner whose plans have none keeps `feedback`
        off), whose nominal rollout must start where the plant will be when they act (else they pull
        it toward a start it has already left)."""
        config = self.controller.config
        return config.latency_compensation or config.feedback

    def _predicted(self, reading: SystemState) -> SystemState:
        """`reading` predicted to when the plan made from it takes effect, under the plans due
        meanwhile."""
        delay = prediction_delay(
            self.latency, self.real_time, self.update_ms, self.cycle_plant_times
        )
        step = self.system.timestep
        if step > 0:  # a plan due between two plant steps takes effect at the later one
            delay = math.ceil(delay / step - 1e-6) * step

        # what `serve` gives the plant in `state`
        def control_at(now: float, state: np.ndarray) -> np.ndarray:
            plan = self.plans.due_at(now)
            if plan is None:
                return self.controller.warm_start_action(reading.state)
            return plan(now, state)

        return self._predictor.predict_reading(reading, delay, control_at)

    def serve(self, now: float) -> np.ndarray:
        """(nu,) the control the plant gets at plant time `now`: the latest plan whose time has come
        (with feedback gains, corrected by the latest reading's deviation from its nominal), or the
        task's warm start (from the latest reading) before the first one; the task's `safe_action`
        instead while the watchdog finds that plan too old, and while the latched stop is
        engaged."""
        # the warm start is held from the first reading after a restart
        active, stamp, hold = self.plans.take_due(now, self._warm_start)
        config, newest = self.controller.config, max(stamp, self.newest_stamp)
        reason = self.watchdog.verdict(
            self.clock(), stamp, config.max_plan_age, config.control_freq, newest
        )
        if self.watchdog.news and self.on_watchdog is not None:
            self.on_watchdog(reason)
        stopped = self.stop if self.stop is not None and self.stop.latched else None
        if stopped is not None:
            stopped.took_effect()
        if reason is not None or stopped is not None:
            return self.safe_action()
        if active is None:
            return hold
        # the state feeds back gains
        return active(now, None if self.reading is None else self.reading.state)

    def _warm_start(self) -> np.ndarray:
        """(nu,) the task's warm start from the latest reading."""
        return self.controller.warm_start_action(
            None if self.reading is None else self.reading.state
        )

    def safe_action(self) -> np.ndarray:
        """(nu,) the task's `safe_action` from the latest finite reading, clamped
        (`judo.loop.timing.safe_action`)."""
        return safe_action(self.controller.task, self._safe_state)

    def halt(self) -> None:
        """Bring the plant to rest: the System's own `halt()` where it offers one, else apply the
        safe action."""
        if not self.calls.halt():
            self.calls.apply(self.safe_action())

    def reset_plant(self) -> SystemState:
        """Reset the plant to its start state and read it (its time may start again). Raises what
        the System's `reset` raised, with the loop as it was; the plans are the caller's to forget
        (`forget_plans`)."""
        self.calls.reset()
        self.watchdog.restart(self.clock())
        self.estimation.restart()
        return self.read()

    def advance(self) -> StepRecord:
        """Serve the plan at the plant's time, step the plant once, read it back and record the
        step.

        apply, step and read_state are each tried on their own, so a failed reading or apply never
        skips the step (a robot's driver exchanges its data in `step`). A diverged simulation (the
        plant reset itself) is counted in `divergences` and re-raised after the step is recorded;
        other failures raise one SystemCallError."""
        reading = self.reading if self.reading is not None else self.read()
        action = self.serve(reading.time)
        if self.guard is not None and not (self.stop is not None and self.stop.latched):
            action = self.guard.filter(
                action, reading.state, reading.time, self.safe_action, reading.metadata
            )
        if self.estimator is not None:  # every served action, for the estimator
            self.estimation.controls.append(reading.time, action)
        failed: dict[str, Exception] = {}  # each call's error but a closed System's
        _attempt(failed, "apply", lambda: self._held_by_stop() or self.calls.apply(action))
        self.stepped_time += self.system.timestep
        diverged: SimulationDiverged | None = None
        try:
            self.calls.step()
        except SimulationDiverged as err:
            self.divergences, diverged = self.divergences + 1, err
        except SystemClosedError:
            raise
        except Exception as err:
            failed["step"] = err
        read = _attempt(failed, "read_state", self.read)
        reading = reading if read is None else read
        true_state = self.system.plant_state()
        raw = self.raw_reading
        record = StepRecord(
            reading.time,
            reading.state if true_state is None else true_state,
            self.system.plant_sensors(),
            action,
            reading.metadata,
            measured=None if raw is None else raw.sensors,
            estimate=None if self.estimator is None else reading.state,
            measured_age=None
            if raw is None or raw.sensors is None
            else self.estimation.measured_age(raw),
            limit_hits=() if self.guard is None else self.guard.step_hits,
        )
        if "read_state" not in failed:
            for recorder in self.recorders:
                recorder.on_step(record)
        if failed:
            raise SystemCallError(failed)
        if diverged is not None:
            raise diverged
        return record

    def _held_by_stop(self) -> bool:
        """Whether the latched stop holds the plant by the System's own halt, so no action is
        applied: halted once per latch where the System offers a halt (else the safe action `serve`
        gave is applied)."""
        stop = self.stop
        if stop is None or not stop.latched:
            self._stop_halted = False
            return False
        if not self._stop_halted and self.calls.offers_halt():
            self._stop_halted = self.calls.halt()
        return self._stop_halted

    def step(self) -> StepRecord | None:
        """Plan when the control clock is due (in sim time: `ControlClock`), then advance the plant
        one step. Returns the step's record, or None when the simulation diverged (counted in
        `divergences`; the plant reset itself)."""
        reading = self.reading if self.reading is not None else self.restart()
        now, period = reading.time, 1.0 / self.controller.config.control_freq
        if self.control_clock.due(now, period):
            self.plan(reading)
            self.control_clock.ticked(now, self.last_delay, period)
        try:
            return self.advance()
        except SimulationDiverged:
            return None


def _attempt(failed: dict[str, Exception], name: str, call: Callable[[], Any]) -> Any:
    """`call()`'s value, or None with its error kept as `failed[name]`; a SystemClosedError is
    raised."""
    try:
        return call()
    except SystemClosedError:
        raise
    except Exception as err:
        failed[name] = err
        return None
