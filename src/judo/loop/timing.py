"""When the loop acts, and whether what it serves is fresh: the clocks, the latency model and the
watchdog.

`PlantClock` says when a System's next `step()` is due in wall time: step k of a stretch at origin
+ k * timestep, the stretch ending at `restart` (a new session, a reset, a pause); a caller more
than `max_catch_up` s behind falls behind rather than bursting to catch up. The app's plant thread,
`excite` and the robot processes pace a System by it:

    due = clock.due(time.perf_counter(), system.timestep)
    for _ in range(due):
        system.step()
    clock.stepped(due)
    time.sleep(clock.wait(time.perf_counter(), system.timestep))

`ControlClock` says when the next control update is due, every 1 / control_freq s: in sim time
under `ClosedLoop.step` (evaluate, tune, collect), in wall time under the app's planner runner.

The latency model: a plan from the reading at time t is served from t + delay, the plant going on
under the plan before meanwhile; with `latency_compensation` (or `feedback`) the loop plans from the
state predicted at the first step at or after t + delay (`LatencyPredictor`). `PlanQueue` holds the
plans waiting for their time, and the one in force.

The watchdog (`Watchdog.verdict`, before each action served, on the loop's clock: plant time in
evaluate and tune, the wall clock in the app): once the plan in force is older than `max_plan_age`
beyond one control period, the plant gets `safe_action` until a fresh plan is served. A plan is as
old as the freshest reading it was planned from; the age's larger part is named as the cause: the
readings stood still (a dead robot, driver, link or sensor stream), or planning lags behind fresher
readings (a hung reward, a slow cycle, a refused reading). A trouble is told (`news`) when it
starts, when the readings turn out to have stopped, every REPORT_EVERY s while it lasts, and at its
end; one of the same cause within REPORT_EVERY s of the last one told is counted instead.
"""

import dataclasses
import math
import threading
from collections.abc import Callable, Sequence
from typing import Literal

import mujoco
import numpy as np

from judo.core.configuration.config import require
from judo.core.errors import ReadingTimeError
from judo.core.reading import TIME_TOLERANCE, SystemState, set_mocap_poses
from judo.core.spline import Spline
from judo.core.task import Task
from judo.loop.system import DIVERGENCE_WARNINGS

MAX_CATCH_UP = 0.1
"""Most seconds of sim time due at once to catch up; beyond that the plant falls behind."""


class PlantClock:
    """Which steps of a plant are due at a wall time (time.perf_counter() seconds), and how long
    until the next: at most `max_catch_up` s of steps at once (at least one). `running`: whether a
    stretch runs (False before the first `due` and after `restart`)."""

    def __init__(self, max_catch_up: float = MAX_CATCH_UP) -> None:
        self.max_catch_up = max_catch_up
        self.running = False
        self._origin = 0.0  # wall time step 0 of the stretch was due
        self._steps = 0  # steps taken in the stretch

    def restart(self) -> None:
        """End the stretch: the next `due` begins a new one, whose first step is due at once."""
        self.running = False

    def due(self, now: float, timestep: float) -> int:
        """Steps of `timestep` s due at wall time `now` and not taken yet, at most `max_catch_up` s
        of them (at least one); begins a stretch at `now` where none runs."""
        if not self.running:
            self._origin, self._steps, self.running = now, 0, True
        due = int((now - self._origin) / timestep) + 1 - self._steps
        most = max(1, round(self.max_catch_up / timestep))
        if due > most:  # too far behind to catch up: fall behind instead
            self._origin += (due - most) * timestep
            due = most
        return max(0, due)

    def stepped(self, count: int) -> None:
        """`count` more steps of the stretch were taken."""
        self._steps += count

    def wait(self, now: float, timestep: float) -> float:
        """Seconds from wall time `now` until the stretch's next step of `timestep` s is due (0 when
        it is due, or when no stretch runs)."""
        if not self.running:
            return 0.0
        return max(0.0, self._origin + self._steps * timestep - now)


class ControlClock:
    """When the next control update is due: `restart(now)` makes one due at `now`, `ticked(now,
    delay, period)` records one made at `now` whose plan takes effect `delay` s later, and an update
    whose plan takes effect after the next tick moves that tick to then. Before the first restart
    every time is due."""

    def __init__(self) -> None:
        self._tick = -math.inf  # the time the latest update came due
        self._not_before = -math.inf  # when the latest update's plan takes effect

    def restart(self, now: float) -> None:
        """Make an update due at `now` (after a reset, whose time may start again, or a pause)."""
        self._tick, self._not_before = -math.inf, now

    def next_time(self, period: float) -> float:
        """The time the next update is due: one `period` after the latest tick, or when its plan
        takes effect if later."""
        return max(self._tick + period, self._not_before)

    def due(self, now: float, period: float) -> bool:
        """Whether an update is due at `now`."""
        return now >= self.next_time(period) - TIME_TOLERANCE

    def ticked(self, now: float, delay: float, period: float) -> None:
        """An update came due and was made at `now`; its plan takes effect at `now + delay`."""
        self._tick, self._not_before = self.next_time(period), now + delay

    def remaining(self, now: float, period: float) -> float:
        """Seconds from `now` until the next update is due (0 when it is due)."""
        return max(0.0, self.next_time(period) - now)


Latency = float | Literal["measured"]
"""Planning latency: seconds of sim time (0 for none), or "measured" for each update's wall time."""


def check_latency(latency: Latency) -> None:
    """Raise ConfigError unless `latency` is "measured" or a finite number of seconds, at least
    0."""
    if latency != "measured":
        require(0 <= latency < math.inf, f"latency must be at least 0 s and finite, got {latency}")


RECENT_CYCLES = 5
"""Cycles whose slowest sets how far ahead a wall-clock loop predicts: a plan that comes early waits
for the time it was planned for, one that comes late starts from a state its rollouts never saw."""


def prediction_delay(
    latency: Latency, real_time: bool, update_ms: list[float], cycle_plant_times: Sequence[float]
) -> float:
    """Seconds ahead that latency compensation predicts a reading: the slowest of the last
    RECENT_CYCLES updates' wall time for a robot (or "measured"), the fixed latency, else the most
    plant time one of the last RECENT_CYCLES cycles took (the app's simulator steps while planning;
    evaluate's does not, so 0 there)."""
    if latency == "measured" or real_time:
        return max(update_ms[-RECENT_CYCLES:]) / 1e3 if update_ms else 0.0
    if float(latency) > 0:
        return float(latency)
    return max(list(cycle_plant_times)[-RECENT_CYCLES:], default=0.0)


class LatencyPredictor:
    """Predicts a reading forward by the planning latency on the task's planning model (its own
    MjData).

    Args:
        task: the controller's task; its `model` steps the prediction.
    """

    def __init__(self, task: Task) -> None:
        # the task's `predict_step` steps the prediction (a DynamicsTask's: its own dynamics)
        self.task = task
        self.model = task.model
        self.data = mujoco.MjData(self.model)

    def predict_reading(
        self,
        reading: SystemState,
        delay: float,
        control_at: Callable[[float, np.ndarray], np.ndarray],
    ) -> SystemState:
        """`reading` moved `delay` seconds ahead: its (nq + nv,) state stepped round(delay /
        timestep) steps with `control_at(time, state)` ((nu,), the control the plant gets at that
        plant time in that (nq + nv,) state: a plan with feedback gains serves by the state), its
        time advanced as far. The reading as it is when the delay is under half a step, it has no
        full state or a non-finite one (the planner refuses that itself), or the prediction diverged
        (MuJoCo resets the data on a bad state, which would otherwise pass for a prediction)."""
        steps = round(delay / self.model.opt.timestep)
        nq, nv = self.model.nq, self.model.nv
        if steps <= 0 or reading.state is None or np.shape(reading.state) != (nq + nv,):
            return reading
        if not (np.isfinite(reading.state).all() and math.isfinite(reading.time)):
            return reading
        data = self.data
        mujoco.mj_resetData(self.model, data)
        data.qpos[:], data.qvel[:], data.time = reading.state[:nq], reading.state[nq:], reading.time
        set_mocap_poses(self.model, data, reading.metadata)
        for _ in range(steps):
            state = np.concatenate([data.qpos, data.qvel])
            data.ctrl[:] = control_at(float(data.time), state)
            self.task.predict_step(self.model, data)
        diverged = any(data.warning[warning].number for warning in DIVERGENCE_WARNINGS)
        if diverged or not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            return reading  # the prediction blew up: plan from what was read
        state = np.concatenate([data.qpos, data.qvel])
        return dataclasses.replace(
            reading, state=state, time=reading.time + steps * self.model.opt.timestep
        )


class PlanQueue:
    """A closed loop's plans that wait for the plant time they take effect at, and the one in force
    (`schedule` runs on the planner's thread and `take_due` on the plant's, each under the lock).

    `stamp`: the watchdog clock of the freshest reading behind the plan in force (the warm start
    counts as a plan from the last `forget`)."""

    def __init__(self, stamp: float) -> None:
        self.stamp = stamp
        self._lock = threading.Lock()
        self._active: Spline | None = None
        # (plant time it takes effect, plan, stamp), in order
        self._pending: list[tuple[float, Spline, float]] = []
        self._hold: np.ndarray | None = None  # (nu,) the warm start served until the first plan

    def forget(self, stamp: float) -> None:
        """Drop every plan: the warm start is served, as a plan from `stamp`, until the next is
        due."""
        with self._lock:
            self._active, self._pending, self._hold = None, [], None
            self.stamp = stamp

    def schedule(self, at: float, plan: Spline, stamp: float) -> None:
        """`plan`, from a reading of watchdog clock `stamp`, takes effect at plant time `at`; it
        replaces each pending plan that would take effect no earlier."""
        with self._lock:
            self._pending = [entry for entry in self._pending if entry[0] < at - TIME_TOLERANCE]
            self._pending.append((at, plan, stamp))

    def due_at(self, now: float) -> Spline | None:
        """The plan in force at plant time `now`, those due by then counted but left pending (None:
        the warm start)."""
        with self._lock:
            due = [plan for at, plan, _ in self._pending if at <= now + TIME_TOLERANCE]
            return due[-1] if due else self._active

    def take_due(
        self, now: float, hold: Callable[[], np.ndarray]
    ) -> tuple[Spline | None, float, np.ndarray | None]:
        """Put in force the plans due by plant time `now`: (the plan in force or None, its stamp,
        and the (nu,) warm start held until the first plan, made by `hold` once after each
        `forget`)."""
        with self._lock:
            while self._pending and self._pending[0][0] <= now + TIME_TOLERANCE:
                _, self._active, self.stamp = self._pending.pop(0)
            if self._active is None and self._hold is None:
                self._hold = hold()
            return self._active, self.stamp, self._hold


REPORT_EVERY = 5.0
"""Seconds of the watchdog's clock between two lines told of the same trouble."""
READINGS_STOPPED = "the readings stopped"
"""How a reason that blames the readings begins."""
PLANNING_LATE = "the plan in force is"
"""How a reason that blames planning begins."""


class Watchdog:
    """Freshness of the readings and of the plan in force, on the loop's clock.

    Attributes:
        fresh_at: clock time at which the latest reading's time last advanced.
        tripped: why the safe action is being served, or None while plans are fresh.
        trips: episodes of trouble so far (each trip counts once until plans are fresh again).
        news: whether the latest verdict is to be told (see the module's docstring): its reason, or
            None for the end of a trouble that was told.
        episode_s: clock seconds the latest trouble has lasted so far, or lasted once it ended.
        resumed_s: clock seconds from the readings' resuming to the end of the latest trouble, where
            they had stopped during it; None otherwise.
    """

    def __init__(self) -> None:
        self.fresh_at = 0.0
        self.tripped: str | None = None
        self.trips = 0
        self.news = False
        self.episode_s = 0.0
        self.resumed_s: float | None = None
        self._last_time: float | None = None
        self._began = 0.0  # clock time the trouble began
        self._cause: str | None = None  # READINGS_STOPPED or PLANNING_LATE, while tripped
        self._readings_stopped = False  # the readings stood still during this trouble
        self._resumed_at: float | None = None  # clock time they advanced again during it
        self._told_at, self._told_cause = -math.inf, None  # the last line told of a trouble
        self._told = False  # this trouble's start was told
        self._untold = 0  # troubles begun and ended untold since the last line told

    def restart(self, now: float) -> None:
        """Start the readings' freshness afresh at clock time `now` (after a reset of the plant,
        whose time may start again at 0). A trouble under way stays until the next verdict finds the
        plan fresh."""
        self.fresh_at, self._last_time = now, None

    def note_reading(self, reading: SystemState, now: float) -> None:
        """Stamp `reading` at clock time `now`: fresh if its time advanced. Raises ReadingTimeError
        if its time went backwards, and keeps the stamps as they were."""
        time = reading.time
        if not math.isfinite(time):  # never fresh; planning refuses it anyway
            return
        if self._last_time is not None and time < self._last_time - TIME_TOLERANCE:
            raise ReadingTimeError(
                f"refused a reading whose time went backwards, from {self._last_time:.6g} s "
                f"to {time:.6g} s; "
                "a System's read_state().time must never decrease (reset the plant to start "
                "it again)"
            )
        if self._last_time is None or time > self._last_time + TIME_TOLERANCE:
            if self._readings_stopped and self._resumed_at is None:
                self._resumed_at = now
            self.fresh_at = now
        self._last_time = time

    def verdict(
        self,
        now: float,
        plan_stamp: float,
        max_plan_age: float,
        control_freq: float,
        newest_stamp: float | None = None,
    ) -> str | None:
        """Why the plan stamped `plan_stamp` must not be served at clock time `now`, or None if it
        may.

        `newest_stamp` is the stamp of the newest plan made (served or still to take effect;
        `plan_stamp` if None): how far it lags behind the freshest reading is planning's share of
        the age. Updates `tripped`, `trips`, `news`, `episode_s` and `resumed_s`. `max_plan_age` 0
        turns the watchdog off.
        """
        age = now - plan_stamp
        if max_plan_age <= 0 or age <= max_plan_age + 1.0 / control_freq:
            self._clear(now)
            return None
        stood = now - self.fresh_at  # how long the readings have stood still
        lag = self.fresh_at - max(plan_stamp, plan_stamp if newest_stamp is None else newest_stamp)
        if stood > lag:
            cause = READINGS_STOPPED
            reason = (
                f"{READINGS_STOPPED}: their time has not advanced for {stood:.2f} s "
                "(is the robot, its driver or the link down, or the sensor stream frozen?)"
            )
        else:
            cause = PLANNING_LATE
            reason = f"{PLANNING_LATE} {age:.2f} s old (planning stalled or failed)"
        self._trip(now, cause)
        if self.news and self._untold:
            reason += (
                f" ({self._untold} shorter episode{'s' if self._untold > 1 else ''} since the "
                "last report)"
            )
            self._untold = 0
        self.tripped = reason
        return reason

    def _trip(self, now: float, cause: str) -> None:
        """Note trouble of `cause` at `now`, and whether it is news."""
        # a new trouble: told unless one of the same cause was told just now
        if self.tripped is None:
            self.trips += 1
            self._began, self._readings_stopped, self._resumed_at = now, False, None
            self._told = cause != self._told_cause or now - self._told_at >= REPORT_EVERY
            self.news = self._told
            if not self._told:
                self._untold += 1
        else:  # told again when the readings turn out to have stopped, and every REPORT_EVERY s
            self.news = (
                cause != self._cause and cause == READINGS_STOPPED
            ) or now - self._told_at >= REPORT_EVERY
            # a trouble counted untold lasted: it is told after all
            if self.news and not self._told:
                self._told, self._untold = True, max(0, self._untold - 1)
        if cause == READINGS_STOPPED:
            self._readings_stopped, self._resumed_at = True, None
        self._cause, self.episode_s = cause, now - self._began
        if self.news:
            self._told_at, self._told_cause = now, cause

    def _clear(self, now: float) -> None:
        """Plans are fresh at `now`: the end of a trouble is news if its start was told."""
        self.news = self.tripped is not None and self._told
        if self.tripped is not None:
            self.episode_s = now - self._began
            self.resumed_s = None if self._resumed_at is None else now - self._resumed_at
        self.tripped, self._cause, self._told = None, None, False


def safe_action(task: Task, state: np.ndarray | None) -> np.ndarray:
    """(command_size,) what the watchdog serves: the task's `safe_action` from the (nq + nv,)
    `state`, the latest finite reading (the planning model's start state when None), clamped to the
    command range."""
    if state is None:
        model = task.model
        state = np.concatenate(
            [model.key_qpos[0] if model.nkey else model.qpos0, np.zeros(model.nv)]
        )
    low, high = task.command_range.T
    return np.clip(np.asarray(task.safe_action(state), dtype=float), low, high)
