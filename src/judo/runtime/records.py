"""What the closed-loop step reports to recorders: one `StepRecord` per plant step, one `PlanRecord` per update.

A `Recorder` plugs into the one closed-loop step once; the app, evaluate, tune and collect all call it,
so every consumer (the dataset writer, plots, the GUI's recording) sees the same records.
"""

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np


@dataclass
class StepRecord:
    """One plant step: what the plant did.

    Attributes:
        time: plant time after the step (s).
        state: (nq + nv,) plant state [qpos, qvel] after the step; None for a robot that measures only sensors.
        sensors: (nsensordata,) plant sensor values after the step (empty for hardware).
        action: (nu,) the control served during the step.
        metadata: the reading's metadata after the step, e.g. "mocap_pos" (nmocap, 3).
    """

    time: float
    state: np.ndarray | None
    sensors: np.ndarray
    action: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass
class PlanRecord:
    """One control update.

    Attributes:
        time: time of the reading the plan was made from (s).
        takes_effect: plant time at which this plan starts being served (s); `time` plus the latency.
        knots: (num_nodes, nu) the new plan's knots.
        update_ms: wall time of the update in milliseconds.
        best_reward: the best rollout reward of the update's last optimizer iteration.
        mean_reward: the mean of that iteration's finite rollout rewards.
    """

    time: float
    takes_effect: float
    knots: np.ndarray
    update_ms: float
    best_reward: float
    mean_reward: float


class Recorder(Protocol):
    """Receives every plan and every plant step of a closed loop, in the order they happen."""

    def on_plan(self, record: PlanRecord) -> None:
        """Called once per control update that produced a plan."""
        ...

    def on_step(self, record: StepRecord) -> None:
        """Called once per plant step, after the step."""
        ...
