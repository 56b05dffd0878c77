"""What the closed loop reports to its recorders: one record per plant step and one per control
update.

A recorder is any object with `on_plan` and `on_step`; the closed loop (`judo.loop.closed_loop`)
calls every recorder it was given, so evaluate's episode log, a dataset writer and the GUI's
recording all see the same thing.
"""

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np


@dataclass
class StepRecord:
    """One plant step.

    Attributes:
        time: plant time after the step, in seconds.
        state: (nq + nv,) [qpos, qvel] after the step: the plant's true state where the System knows
            it (a simulator), else the reading's; None for a robot that measures only sensors.
        sensors: (nsensordata,) the plant's sensor values after the step (empty when the plant has
            none to give).
        action: (nu,) the control served during the step.
        metadata: the reading's metadata, e.g. "mocap_pos" (nmocap, 3).
        measured: the measured sensors of the reading (task.measured.size,), where the System gives
            them.
        estimate: (nq + nv,) the estimator's state after the step, where an estimator runs.
        measured_age: (k,) seconds between taking each measured sensor's value in `measured` and the
            plant's time after the step (its reading's "sensor_times", else its time), where the
            System gives measured sensors.
        limit_hits: the limits the serve filter enforced on this step's
            action (`judo.safety.serve_filter.LimitHit`: time, limit, value); empty without [safety]
            limits.
    """

    time: float
    state: np.ndarray | None
    sensors: np.ndarray
    action: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    measured: np.ndarray | None = None
    estimate: np.ndarray | None = None
    measured_age: np.ndarray | None = None
    limit_hits: tuple[Any, ...] = ()


@dataclass
class PlanRecord:
    """One control update.

    Attributes:
        time: time of the reading planned from, in seconds.
        takes_effect: plant time from which the new plan is served (time + the latency model's
            delay).
        knots: (num_nodes, nu) the new plan's knots.
        update_ms: wall time of the update in milliseconds.
        best_reward, mean_reward: the best and the mean finite reward of the update's last
            iteration.
        traces: (1 + num_shown, T, num_trace_sensors, 3) float32 copy of the
            controller's `traces` (the trace sensors along the nominal and the best rollouts), only
            when a recorder's `wants_traces` asks for it; else None.
    """

    time: float
    takes_effect: float
    knots: np.ndarray
    update_ms: float
    best_reward: float
    mean_reward: float
    traces: np.ndarray | None = None

    @classmethod
    def of_update(
        cls,
        time: float,
        delay: float,
        knots: np.ndarray,
        wall: float,
        rewards: np.ndarray,
        traces: np.ndarray | None,
    ) -> "PlanRecord":
        """The record of an update planned from the reading at `time`, served `delay` s later, that
        took `wall` s and scored (num_rollouts,) `rewards` (only the finite ones count)."""
        finite = rewards[np.isfinite(rewards)]
        best = float(finite.max()) if len(finite) else math.nan
        mean = float(finite.mean()) if len(finite) else math.nan
        return cls(time, time + delay, knots, 1e3 * wall, best, mean, traces)


class Recorder(Protocol):
    """Receives every control update and every plant step of a closed loop, in order.

    A recorder with a true attribute `wants_traces` gets each PlanRecord with its `traces`; the loop
    copies them only then (evaluate and tune do without the copy).
    """

    def on_plan(self, record: PlanRecord) -> None:
        """Called after each successful control update."""
        ...

    def on_step(self, record: StepRecord) -> None:
        """Called after each plant step."""
        ...
