"""Cylinder push: drive a pusher disc so it shoves a free cart disc onto a goal position."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import np_1d_field, slider
from judo.core.norms import quadratic_norm
from judo.core.rollouts.randomize import (
    body_id,
    contact_geom_ids,
    scale_body_mass,
    scale_dof_frictionloss,
    scale_geom_friction,
)
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "cylinder_push.xml"


@slider("w_pusher_proximity", 0.0, 5.0, 0.01)
@slider("w_pusher_velocity", 0.0, 1.0, 0.01)
@slider("w_cart_position", 0.0, 5.0, 0.01)
@slider("pusher_goal_offset", 0.0, 1.0, 0.01)
@dataclass
class CylinderPushConfig(TaskConfig):
    """Cylinder-push reward weights and goal."""

    w_pusher_proximity: float = 0.5
    """Weight on the pusher sitting behind the cart, on the far side from the goal."""
    w_pusher_velocity: float = 0.0
    """Weight on a slow pusher."""
    w_cart_position: float = 1.0
    """Weight on the cart reaching the goal."""
    pusher_goal_offset: float = 0.35
    """How far behind the cart's centre (m) the pusher should be, along the cart-to-goal line."""
    goal_pos: np.ndarray = np_1d_field(
        np.array([0.0, 0.0]),
        names=["x", "y"],
        mins=[-1.0, -1.0],
        maxs=[1.0, 1.0],
        steps=[0.01, 0.01],
        vis_name="goal",
    )
    """Goal position (m) of the cart on the table."""


class CylinderPush(Task[CylinderPushConfig]):
    """State [pusher x, y, cart x, y, and their velocities]; controls are the x, y forces on the
    pusher."""

    measured_sensors = ("pusher_x_pos", "pusher_y_pos", "cart_x_pos", "cart_y_pos")
    lower_is_better = ("final_distance",)
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
        config: CylinderPushConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        pusher, cart, pusher_vel = states[..., 0:2], states[..., 2:4], states[..., 4:6]
        to_goal = config.goal_pos - cart
        direction = to_goal / np.maximum(np.linalg.norm(to_goal, axis=-1, keepdims=True), 1e-6)
        pusher_target = cart - config.pusher_goal_offset * direction
        return -(
            config.w_pusher_proximity * quadratic_norm(pusher - pusher_target).sum(-1)
            + config.w_pusher_velocity * quadratic_norm(pusher_vel).sum(-1)
            + config.w_cart_position * quadratic_norm(to_goal).sum(-1)
        )

    def reset(self) -> None:
        """Cart 1 m from the goal in a random direction; pusher on a random spot 0.5-1 m from the
        cart."""
        cart_angle, pusher_angle = self.rng.uniform(0, 2 * np.pi, 2)
        cart = self.config.goal_pos + np.array([np.cos(cart_angle), np.sin(cart_angle)])
        pusher = cart + self.rng.uniform(0.5, 1.0) * np.array(
            [np.cos(pusher_angle), np.sin(pusher_angle)]
        )
        self.data.qpos[:] = np.concatenate([pusher, cart])
        self.data.qvel[:] = 0.0
        mujoco.mj_forward(self.sim_model, self.data)

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Pusher-cart friction x U[0.7, 1.3] per geom, the cart's mass x U[0.8, 1.25], and the
        cart's friction loss (the table's friction) x U[0.7, 1.3]."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)
        scale_body_mass(model, body_id(model, "cart"), 0.8, 1.25, rng)
        dofs = [int(model.joint(name).dofadr[0]) for name in ("cart_x", "cart_y")]
        scale_dof_frictionloss(model, dofs, 0.7, 1.3, rng)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """Where the cart ended: "final_distance" to the goal (m), and "reached", 1.0 if that is
        under 0.05 m."""
        distance = float(np.linalg.norm(log.states[-1, 2:4] - self.config.goal_pos))
        return {"final_distance": distance, "reached": float(distance < 0.05)}

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: "reached" (the cart ended within 0.05 m of the
        goal)."""
        return bool(metrics["reached"] > 0.5)
