"""Pendulum swing-up: a torque-limited motor pumps a hanging pole up and balances it upright."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.norms import quadratic_norm, smooth_l1_norm, wrap_angle
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "pendulum.xml"
UPRIGHT_TOLERANCE = 0.3
"""Angle from vertical (rad) within which the pole counts as upright in `metrics`."""
FINAL_WINDOW = 3.0
"""Seconds at the end of an episode over which `metrics` measures the upright fraction."""


@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.01)
@dataclass
class PendulumConfig(TaskConfig):
    """Pendulum reward weights."""

    w_upright: float = 10.0
    """Weight on the pole pointing up (a smooth |angle from vertical|, in rad)."""
    w_velocity: float = 0.05
    """Weight on a slow pole; too much of it stops the pumping that the swing-up needs."""
    w_control: float = 0.01
    """Weight on small torques."""


class Pendulum(Task[PendulumConfig]):
    """State [pole angle (0 = upright), angular velocity]; one control, the hinge torque (2 Nm at
    1).

    Gravity needs 4.9 Nm to hold the pole level, so the controller has to swing it up in several
    pumps.
    """

    measured_sensors = ("hinge_pos",)
    lower_is_better = ("final_angle_error",)
    focus_body = "pole"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: PendulumConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        angle, velocity = states[..., 0:1], states[..., 1:2]
        upright = smooth_l1_norm(wrap_angle(angle), 0.1)
        return -(
            config.w_upright * upright.sum(-1)
            + config.w_velocity * quadratic_norm(velocity).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 3) [cos angle, sin angle, angular velocity] of (B, 2) states.

        The hinge is unlimited: the pole's pumping and any full turn leave the raw angle at 2 pi, 4
        pi, ... for the same pose, which a learned policy would have to meet in its data at every
        one of them; cos and sin are the same there.
        """
        states = np.asarray(states, dtype=float)
        return np.column_stack([np.cos(states[:, 0]), np.sin(states[:, 0]), states[:, 1]])

    def reset(self) -> None:
        """Pole hanging down, within 0.3 rad, with a small random spin."""
        self.data.qpos[:] = np.pi + self.rng.uniform(-0.3, 0.3)
        self.data.qvel[:] = self.rng.normal(0.0, 0.2)
        mujoco.mj_forward(self.sim_model, self.data)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """upright_fraction: share of the last 3 s with the pole within 0.3 rad of vertical;
        final_angle_error: |angle from vertical| (rad) at the end."""
        angle_error = np.abs(wrap_angle(log.states[:, 0]))
        final = log.times >= log.times[-1] - FINAL_WINDOW
        return {
            "upright_fraction": float(np.mean(angle_error[final] < UPRIGHT_TOLERANCE)),
            "final_angle_error": float(angle_error[-1]),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: the pole upright over at least 90% of the final 3
        s."""
        return bool(metrics["upright_fraction"] >= 0.9)
