"""What the app's loops publish in the StateBuffer for the GUI and scripts: plant readings and plans."""

from dataclasses import dataclass

import numpy as np

from judo.loop.system import SystemState


@dataclass(frozen=True)
class SystemSnapshot:
    """What the system loop publishes under "system": the plant reading of one session.

    Attributes:
        generation: the session that read it.
        reading: the state the next plan starts from: the estimate when an estimator runs, else the reading.
        true_state: (nq + nv,) the simulated plant's true state when an estimator runs (the GUI draws it as
            the robot and the estimate as a ghost); None otherwise, and for a user's System.
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
        resets: plant resets done before the state planned from was read; a plan from before the latest reset is
            stale, and the GUI never draws its traces over the reset plant.
    """

    generation: int
    time: float
    nominal_knots: np.ndarray
    rewards: np.ndarray
    traces: np.ndarray
    plan_time: float
    resets: int = 0
