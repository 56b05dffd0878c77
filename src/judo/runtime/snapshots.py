"""What the app's loops publish for the GUI and scripts: plant readings and plans in the
StateBuffer, and the run's figures in `RunStats` (plan times, control rate, real-time factor:
`LiveFigures` for the GUI's plots, `RunSummary` at exit).

`StateBuffer` is the one place the app's loops exchange data: the latest value of each topic, as a
versioned snapshot.

A writer publishes a value; the buffer stores a deep copy whose arrays are read-only, under a lock,
and stamps it with the next version number. A reader gets that stored snapshot whole. Since a
published snapshot is never written again, a reader can never see half of one write and half of
another (no torn reads), however the threads interleave.

A reader that wants each snapshot as it comes subscribes (`subscribe(topic, callback)`): the
callback runs on the publisher's thread (the plant's or the planner's) right after the snapshot is
stored. `Subscribers` holds the callbacks of one event for the app's other news (config changes,
resets, switches). A callback must be cheap: keep the newest value and let its own thread act on it;
one that raises is logged and the publisher goes on.
"""

import copy
import dataclasses
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from judo.core.reading import SystemState
from judo.safety.stop import StopEvent, StopLatch


@dataclass(frozen=True)
class SystemSnapshot:
    """What the system loop publishes under "system": the plant reading of one session.

    Attributes:
        generation: the session that read it.
        reading: the state the next plan starts from: the estimate when an estimator runs, else the
            reading.
        true_state: (nq + nv,) the simulated plant's true state when an estimator runs (the GUI
            draws it as the robot and the estimate as a ghost); None otherwise, and for a user's
            System.
    """

    generation: int
    reading: SystemState
    true_state: np.ndarray | None = None


@dataclass(frozen=True)
class PlanSnapshot:
    """What the controller loop publishes under "plan" after each planning cycle.

    Attributes:
        generation: the session that planned.
        time: sim time of the state planned from.
        nominal_knots: (num_nodes, nu) knots of the new plan.
        rewards: (num_rollouts,) rewards of the last iteration (index 0 is the nominal).
        traces: (1 + num_shown, T, num_trace_sensors, 3) trace-sensor positions, nominal first.
        plan_time: wall-clock seconds the cycle took.
        resets: plant resets done before the state planned from was read; a plan from before the
            latest reset is stale, and the GUI never draws its traces over the reset plant.
    """

    generation: int
    time: float
    nominal_knots: np.ndarray
    rewards: np.ndarray
    traces: np.ndarray
    plan_time: float
    resets: int = 0


T = TypeVar("T")

logger = logging.getLogger("judo.app")


class Subscribers:
    """The callbacks of one event, called in the order added on the thread that fires it."""

    def __init__(self) -> None:
        self._callbacks: tuple[Callable[..., None], ...] = ()
        self._lock = threading.Lock()

    def add(self, callback: Callable[..., None]) -> None:
        """Call `callback` with the event's arguments each time it fires, from now on."""
        with self._lock:
            self._callbacks = (*self._callbacks, callback)

    def fire(self, *args: Any) -> None:
        """Call every callback with `args`; one that raises is logged, and the others are still
        called."""
        for callback in self._callbacks:
            try:
                callback(*args)
            except Exception:
                logger.exception("a subscriber's callback failed")


@dataclass(frozen=True)
class Snapshot(Generic[T]):
    """One published value.

    Attributes:
        version: position of this publication among all of the buffer's, counting from 1.
        value: a private deep copy of what was published; its numpy arrays are read-only.
        wall_time: `time.perf_counter()` when it was published.
    """

    version: int
    value: T
    wall_time: float


class StateBuffer:
    """Latest snapshot per topic (e.g. "system", "plan"), safe to share between threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._latest: dict[str, Snapshot[Any]] = {}
        self._version = 0
        self._subscribers: dict[str, Subscribers] = {}

    def subscribe(self, topic: str, callback: Callable[[Snapshot[Any]], None]) -> None:
        """Call `callback(snapshot)` with each snapshot of `topic` published from now on, on the
        publisher's thread."""
        with self._lock:
            subscribers = self._subscribers.setdefault(topic, Subscribers())
        subscribers.add(callback)

    def publish(self, topic: str, value: T) -> Snapshot[T]:
        """Store a frozen copy of `value` as the newest snapshot of `topic` and return it.

        The copy is made before taking the lock, so the caller may reuse or change `value` at once.
        """
        frozen = _freeze(copy.deepcopy(value))
        with self._lock:
            self._version += 1
            snapshot = Snapshot(self._version, frozen, time.perf_counter())
            self._latest[topic] = snapshot
            subscribers = self._subscribers.get(topic)
        if subscribers is not None:
            subscribers.fire(snapshot)
        return snapshot

    def latest(self, topic: str) -> Snapshot[Any] | None:
        """The newest snapshot of `topic`, or None if nothing was published to it yet."""
        with self._lock:
            return self._latest.get(topic)

    def clear(self, topic: str) -> None:
        """Forget `topic`, e.g. the old plan after a switch of task."""
        with self._lock:
            self._latest.pop(topic, None)


def _freeze(value: Any) -> Any:
    """Mark every numpy array reachable through dicts, lists, tuples and dataclasses read-only."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, dict):
        for item in value.values():
            _freeze(item)
    elif isinstance(value, (list, tuple)):
        for item in value:
            _freeze(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _freeze(getattr(value, f.name))
    return value


@dataclass(frozen=True)
class RunSummary:
    """What `python -m judo --duration` prints at the end of a run.

    Attributes:
        task, optimizer: registry names in use at the end.
        sim_time: seconds of plant time stepped (pauses excluded).
        wall_time: wall-clock seconds the plant loop ran unpaused.
        num_plans: planning cycles completed.
        control_rate: planning cycles per wall-clock second.
        plan_time_mean_ms: mean wall time of one planning cycle over the whole run.
        plan_time_p95_ms: its 95th percentile over the last PLAN_TIMES_KEPT cycles.
        real_time_factor: sim_time / wall_time (1 = real time).
        final_reward: reward of the nominal rollout in the last cycle (NaN if none ran).
        stops: each latch and clear of the latched stop in the run (`judo.safety.stop`);
            stop_latched: still at exit.
    """

    task: str
    optimizer: str
    sim_time: float
    wall_time: float
    num_plans: int
    control_rate: float
    plan_time_mean_ms: float
    plan_time_p95_ms: float
    real_time_factor: float
    final_reward: float
    stops: tuple[StopEvent, ...] = ()
    stop_latched: bool = False
    limits: str | None = None
    """The [safety] limits' serve filter's line (commands filtered, replaced, hits by limit); None
    without limits."""

    def __str__(self) -> str:
        rows = [
            ("task", self.task),
            ("optimizer", self.optimizer),
            ("sim time", f"{self.sim_time:.2f} s in {self.wall_time:.2f} s wall"),
            ("control rate", f"{self.control_rate:.1f} Hz ({self.num_plans} plans)"),
            (
                "plan time",
                f"mean {self.plan_time_mean_ms:.2f} ms, p95 {self.plan_time_p95_ms:.2f} ms",
            ),
            ("real-time factor", f"{self.real_time_factor:.3f}"),
            (
                "final reward",
                f"{self.final_reward:.4g}"
                if np.isfinite(self.final_reward)
                else "none (no rollout scored)",
            ),
        ]
        rows += [("stop", event.line()) for event in self.stops]
        if self.stop_latched:
            rows.append(
                (
                    "stop",
                    "still latched at exit: the next start serves the safe action until it is "
                    "cleared",
                )
            )
        if self.limits is not None:
            rows.append(("limits", self.limits))
        return "\n".join(f"{name:>16}: {value}" for name, value in rows)


@dataclass(frozen=True)
class LiveFigures:
    """The figures the GUI plots, rates over the last `window` seconds; NaN where there is no data
    yet."""

    nominal_reward: float
    plan_time_ms: float
    control_rate: float
    real_time_factor: float


PLAN_TIMES_KEPT = 10_000
"""Plan times a RunStats keeps for the p95 (older ones only count towards the mean), so a long run's
memory stays bounded."""


class RunStats:
    """Collects plan and plant timings from the app's loops; safe to read from any thread.

    Memory is bounded however long the app runs: the last PLAN_TIMES_KEPT plan times, a count and a
    sum.
    """

    def __init__(self, window: float = 1.0) -> None:
        self.window = window
        self._lock = threading.Lock()
        self._plan_times: deque[float] = deque(maxlen=PLAN_TIMES_KEPT)
        self._num_plans = 0
        self._plan_time_total = 0.0
        self._recent_plan_starts: deque[float] = deque()
        self._first_plan_start: float | None = None
        self._last_plan_start: float | None = None
        self._nominal_reward = float("nan")
        self._sim_time = 0.0
        self._wall_time = 0.0
        self._recent_progress: deque[tuple[float, float]] = deque()  # (perf_counter, sim_time)

    def record_plan(self, start: float, duration: float, nominal_reward: float) -> None:
        """One planning cycle that began at `time.perf_counter()` value `start` and took `duration`
        s."""
        with self._lock:
            self._plan_times.append(duration)
            self._num_plans += 1
            self._plan_time_total += duration
            self._recent_plan_starts.append(start)
            if self._first_plan_start is None:
                self._first_plan_start = start
            self._last_plan_start = start
            self._nominal_reward = nominal_reward
            while self._recent_plan_starts[0] < start - self.window:
                self._recent_plan_starts.popleft()

    def record_plant(self, sim_dt: float, wall_dt: float) -> None:
        """The plant advanced `sim_dt` seconds of sim time during `wall_dt` unpaused wall-clock
        seconds."""
        now = time.perf_counter()
        with self._lock:
            self._sim_time += sim_dt
            self._wall_time += wall_dt
            self._recent_progress.append((now, self._sim_time))
            while (
                len(self._recent_progress) > 2 and self._recent_progress[1][0] < now - self.window
            ):
                self._recent_progress.popleft()

    def sim_time(self) -> float:
        """Seconds of plant time stepped so far."""
        with self._lock:
            return self._sim_time

    def num_plans(self) -> int:
        """Planning cycles completed so far."""
        with self._lock:
            return self._num_plans

    def live(self) -> LiveFigures:
        """The latest reward and plan time, and the rates over the last `window` seconds."""
        with self._lock:
            starts = self._recent_plan_starts
            rate = (len(starts) - 1) / (starts[-1] - starts[0]) if len(starts) > 1 else float("nan")
            plan_ms = 1000.0 * self._plan_times[-1] if self._plan_times else float("nan")
            rtf = float("nan")
            if len(self._recent_progress) > 1:
                (w0, s0), (w1, s1) = self._recent_progress[0], self._recent_progress[-1]
                rtf = (s1 - s0) / (w1 - w0) if w1 > w0 else float("nan")
            return LiveFigures(self._nominal_reward, plan_ms, rate, rtf)

    def summary(
        self, task: str, optimizer: str, stop: StopLatch | None = None, limits: str | None = None
    ) -> RunSummary:
        """Figures over the whole run so far, with the events of the latched `stop` and the `limits`
        line."""
        with self._lock:
            times, count = np.array(self._plan_times), self._num_plans
            span = 0.0
            if self._first_plan_start is not None and self._last_plan_start is not None:
                span = self._last_plan_start - self._first_plan_start
            return RunSummary(
                task=task,
                optimizer=optimizer,
                sim_time=self._sim_time,
                wall_time=self._wall_time,
                num_plans=count,
                control_rate=(count - 1) / span if span > 0 else float("nan"),
                plan_time_mean_ms=1000.0 * self._plan_time_total / count if count else float("nan"),
                plan_time_p95_ms=1000.0 * float(np.percentile(times, 95))
                if len(times)
                else float("nan"),
                real_time_factor=self._sim_time / self._wall_time
                if self._wall_time > 0
                else float("nan"),
                final_reward=self._nominal_reward,
                stops=() if stop is None else tuple(stop.events),
                stop_latched=stop is not None and stop.latched,
                limits=limits,
            )
