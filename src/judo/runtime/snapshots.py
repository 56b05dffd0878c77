"""The values the app's threads publish and show: the plant's readings and the plans as published
(`SystemSnapshot`, `PlanSnapshot`, each stored as a versioned `Snapshot` in the StateBuffer of
`judo.runtime.exchange`), the run's figures (`LiveFigures` for the GUI's plots, `RunSummary` at
exit) and the planning cycle's cost line (`CycleCost`). `Subscribers` holds the callbacks of one
event: the StateBuffer's topics and the app's other news (config changes, resets, switches).
"""

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from judo.core.planner_view import CycleSize
from judo.core.reading import SystemState
from judo.safety.stop import StopEvent


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
        plan_time_p95_ms: its 95th percentile over the last PLAN_TIMES_KEPT cycles (RunStats).
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


@dataclass(frozen=True)
class CycleCost:
    """What the GUI shows of the cycle: the configs' size and estimated seconds, the last completed
    cycle's seconds, and how long the cycle in flight has run when it is late (else None)."""

    size: CycleSize | None
    estimate: float
    last: float
    running_for: float | None

    def line(self) -> str:
        """The cost as one line: 'cycle 64 x 1 x 1 x 100 = 6,400 steps, est. 12 ms; last plan 9.8
        ms'."""
        if self.size is None:
            return f"last update {seconds_text(self.last)}"
        estimated = f", est. {seconds_text(self.estimate)}" if math.isfinite(self.estimate) else ""
        text = f"cycle {self.size}{estimated}; last plan {seconds_text(self.last)}"
        if self.running_for is not None:
            text += f"; planning: {self.running_for:.0f} s so far"
        return text


def seconds_text(seconds: float) -> str:
    """'9.8 ms', '1.2 s', '-' for NaN."""
    if not math.isfinite(seconds):
        return "-"
    return f"{1e3 * seconds:.1f} ms" if seconds < 1 else f"{seconds:.1f} s"
