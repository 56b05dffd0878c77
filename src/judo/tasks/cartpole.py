"""Cart-pole swing-up: push the cart so the pole swings up from hanging and balances upright,
centred."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "cartpole.xml"


@slider("w_vertical", 0.0, 50.0, 0.1)
@slider("w_centered", 0.0, 50.0, 0.1)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.01)
@dataclass
class CartpoleConfig(TaskConfig):
    """Cart-pole reward weights."""

    w_vertical: float = 10.0
    """Weight on the pole being upright."""
    w_centered: float = 10.0
    """Weight on the cart being at the rail's centre."""
    w_velocity: float = 0.1
    """Weight on small cart and pole velocities."""
    w_control: float = 0.1
    """Weight on small pushes."""


class Cartpole(Task[CartpoleConfig]):
    """State [cart x, pole angle (0 = upright), their velocities]; one control, the push on the
    cart."""

    measured_sensors = ("slider_pos", "hinge_pos")
    focus_body = "cart"

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
        config: CartpoleConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        # Elementwise forms of smooth_l1_norm and quadratic_norm on scalars: half the numpy calls.
        cart_x, cart_vel, pole_vel = states[..., 0], states[..., 2], states[..., 3]
        upright_error = np.cos(states[..., 1]) - 1.0
        vertical = np.sqrt(upright_error**2 + 0.01**2) - 0.01
        centered = np.sqrt(cart_x**2 + 0.1**2) - 0.1
        velocity = 0.5 * (cart_vel**2 + pole_vel**2)
        control = 0.5 * controls[..., 0] ** 2
        per_step = (
            config.w_vertical * vertical
            + config.w_centered * centered
            + config.w_velocity * velocity
            + config.w_control * control
        )
        return -per_step.sum(-1)

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 5) [cart x, cos angle, sin angle, cart velocity, angular velocity] of (B, 4) states.

        The pole's hinge is unlimited: a swing-up ends at 0 or 2 pi (or 4 pi after a full turn), one
        pose that a learned policy would otherwise have to meet in its data at each of those angles;
        cos and sin are the same there. A law written for [x, angle, velocities] near upright reads
        sin angle as the angle.
        """
        states = np.asarray(states, dtype=float)
        angle = states[:, 1]
        return np.column_stack(
            [states[:, 0], np.cos(angle), np.sin(angle), states[:, 2], states[:, 3]]
        )

    def reset(self) -> None:
        """Pole hanging down, cart near the centre, small random velocities."""
        self.data.qpos[:] = [0.0, np.pi] + self.rng.normal(0.0, [0.2, 0.2])
        self.data.qvel[:] = self.rng.normal(0.0, 0.1, 2)
        mujoco.mj_forward(self.sim_model, self.data)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """Balance over the final 3 s (the whole episode if shorter).

        "balanced_fraction" is the share of those steps with the pole upright (cos(angle) > 0.9) and
        the cart centred (|x| < 0.3 m); "swung_up" is 1.0 if that share is over 0.9, else 0.0.
        """
        final = log.times > log.times[-1] - 3.0 + 1e-9  # steps ending within the final 3 s
        cart_x, angle = log.states[final, 0], log.states[final, 1]
        fraction = float(np.mean((np.cos(angle) > 0.9) & (np.abs(cart_x) < 0.3)))
        return {"balanced_fraction": fraction, "swung_up": float(fraction > 0.9)}

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: "swung_up" (the pole balanced over 90% of the final
        3 s)."""
        return bool(metrics["swung_up"] > 0.5)
