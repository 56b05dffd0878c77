"""When the loop acts: the two clocks (when a System's next step and the next control update are
due) and the latency model (when a plan takes effect, and the prediction that compensates for it).

## The clocks

The plant clock (`PlantClock`) says when a System's next `step()` is due in wall time, the control
clock (`ControlClock`) when the next control update is due. The plant clock steps a plant once per
`timestep` of wall clock (docs/hardware.md). The app's plant thread and `python -m judo excite` both
pace a System by it.

Step k of a stretch is due at wall time origin + k * timestep, the origin being the wall time the
stretch began (its first step is due at once). `restart` ends the stretch: the next `due` begins a
new one (after a new session, a reset, a pause, a wait for the planner). A caller that falls further
behind than `max_catch_up` seconds at once falls behind instead: at most that many seconds of steps
are due at once, and the origin moves on by the rest, so a slow `step()` slows the plant down (the
real-time factor shows it) rather than bursting to catch up.

    clock = PlantClock()
    while running:
        now = time.perf_counter()
        due = clock.due(now, system.timestep)
        for _ in range(due):
            system.step()
        clock.stepped(due)
        time.sleep(clock.wait(time.perf_counter(), system.timestep))

The control clock is ticked in sim time by `ClosedLoop.step` (evaluate, tune, collect) and in wall
time by the app's planner runner. It ticks every 1 / control_freq s, read when asked (an edit takes
effect at once); an update whose plan takes effect after the next tick moves that tick to then,
since a controller cannot start a plan before the current one is done.

## The latency model

A plan computed from the reading at time t is served from t + delay (`judo.loop.closed_loop`). Until
then the plant goes on under the plan in force before it, so a plan whose rollouts start from the
reading's state plans the first `delay` seconds for a state the plant has already left. With the
controller's `latency_compensation` (and with `feedback` gains), the closed loop first predicts the
plant's state at the first plant step at or after t + delay on the planning model, under the
controls it will actually be served meanwhile, and plans from there (`predict_reading`); such a plan
takes effect no earlier than that step, where its rollouts start. `PlanQueue` holds the plans that
wait for their time, and the one in force.
"""

import dataclasses
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Literal

import mujoco
import numpy as np

from judo.core.configuration.config import require
from judo.core.reading import TIME_TOLERANCE, SystemState, set_mocap_poses
from judo.core.spline import Spline
from judo.core.task import Task
from judo.loop.system import DIVERGENCE_WARNINGS

MAX_CATCH_UP = 0.1
"""Most seconds of sim time due at once to catch up; beyond that the plant falls behind."""
STOP_POLL = 0.05
"""Most seconds `sleep_until_due` sleeps before it asks again whether to stop."""


class PlantClock:
    """Which steps of a plant are due at a wall time (time.perf_counter() seconds), and how long
    until the next.

    Args:
        max_catch_up: most seconds of steps due at once (at least one step).

    Attributes:
        running: whether a stretch runs (False before the first `due` and after `restart`).
    """

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

    def sleep_until_due(self, timestep: float, stopped: Callable[[], bool]) -> bool:
        """Sleep until a step of `timestep` s is due (True), or until `stopped()` (False), asking it
        at least every STOP_POLL s: the wait of a caller that steps one step at a time."""
        while not stopped():
            now = time.perf_counter()
            if self.due(now, timestep):
                return True
            time.sleep(min(self.wait(now, timestep), STOP_POLL))
        return False


class ControlClock:
    """When the next control update is due.

    `restart(now)` makes an update due at `now`; `ticked(now, delay, period)` records an update made
    at `now` whose plan takes effect `delay` s later. Before the first restart every time is due.
    """

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
    """A closed loop's plans that wait for the plant time they take effect at, and the one in force.

    `schedule` runs on the planner's thread and `take_due` on the plant's; each holds the queue's
    lock.

    Attributes:
        stamp: the watchdog clock of the freshest reading behind the plan in force (the warm start
            counts as a plan from the last `forget`).
    """

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
