"""Push-T: a round pusher shoves a T-shaped block until it lies on a goal position and heading."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.model import mocap_pose
from judo.core.norms import quadratic_norm, smooth_l1_norm, wrap_angle
from judo.core.rollouts.randomize import (
    body_id,
    contact_geom_ids,
    scale_body_mass,
    scale_dof_frictionloss,
    scale_geom_friction,
)
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "push_t.xml"
POSITION_TOLERANCE = 0.02
"""Block position error (m) under which `metrics` counts the block as placed (with the angle
below)."""
ANGLE_TOLERANCE = 0.1
"""Block heading error (rad) under which `metrics` counts the block as placed (with the position
above)."""


@slider("w_position", 0.0, 50.0, 0.1)
@slider("w_orientation", 0.0, 10.0, 0.01)
@slider("w_proximity", 0.0, 10.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.001)
@slider("push_offset", 0.0, 0.3, 0.005)
@dataclass
class PushTConfig(TaskConfig):
    """Push-T reward weights. The goal pose is the mocap body "goal": drag and turn it in the
    GUI."""

    w_position: float = 10.0
    """Weight on the block's distance (m) from the goal position."""
    w_orientation: float = 1.0
    """Weight on the block's heading error (rad) from the goal's heading."""
    w_proximity: float = 0.3
    """Weight on the pusher's distance (m) from a spot behind the block, on the far side from the
    goal."""
    push_offset: float = 0.12
    """How far (m) behind the block's centre that spot is; it shrinks to zero as the block nears the
    goal."""
    w_control: float = 0.01
    """Weight on small pusher forces."""


def yaw_of(quaternions: np.ndarray) -> np.ndarray:
    """(...,) heading (rad) of (..., 4) [w, x, y, z] quaternions that rotate about the vertical
    only."""
    return 2.0 * np.arctan2(quaternions[..., 3], quaternions[..., 0])


class PushT(Task[PushTConfig]):
    """State [block x, y, heading, pusher x, y, and their velocities]; controls are the x, y forces
    on the pusher (5 N at 1). The planner reads the block and goal poses through framepos/framequat
    sensors."""

    measured_sensors = (
        "block_x_pos",
        "block_y_pos",
        "block_yaw_pos",
        "pusher_x_pos",
        "pusher_y_pos",
    )
    lower_is_better = ("final_position_error", "final_angle_error")
    focus_body = "block"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._columns = {
            name: self.get_sensor_start_index(name)
            for name in (
                "trace_pusher",
                "trace_block",
                "block_orientation",
                "goal_position",
                "goal_orientation",
            )
        }
        self.reset()

    def errors(self, sensors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(...,) block position error (m) and (...,) signed heading error (rad) from (...,
        nsensordata)."""
        c = self._columns
        block, goal = (
            sensors[..., c["trace_block"] : c["trace_block"] + 2],
            sensors[..., c["goal_position"] : c["goal_position"] + 2],
        )
        block_yaw = yaw_of(sensors[..., c["block_orientation"] : c["block_orientation"] + 4])
        goal_yaw = yaw_of(sensors[..., c["goal_orientation"] : c["goal_orientation"] + 4])
        return np.linalg.norm(block - goal, axis=-1), wrap_angle(block_yaw - goal_yaw)

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: PushTConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        c = self._columns
        position_error, angle_error = self.errors(sensors)
        pusher = sensors[..., c["trace_pusher"] : c["trace_pusher"] + 2]
        block = sensors[..., c["trace_block"] : c["trace_block"] + 2]
        to_goal = sensors[..., c["goal_position"] : c["goal_position"] + 2] - block
        behind = block - config.push_offset * to_goal / np.maximum(
            np.linalg.norm(to_goal, axis=-1, keepdims=True), 0.05
        )
        return -(
            config.w_position * smooth_l1_norm(position_error[..., None], 0.02).sum(-1)
            + config.w_orientation * smooth_l1_norm(angle_error[..., None], 0.1).sum(-1)
            + config.w_proximity * smooth_l1_norm(pusher - behind, 0.05).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 13) the block, pusher and goal relative to the block, in the world frame the pusher forces act in:

            [0:2]   goal x, y - block x, y (m)
            [2:4]   cos, sin of the heading error, block heading - goal heading
            [4:6]   pusher x, y - block x, y (m)
            [6:8]   cos, sin of the block's heading (its hinge is unlimited: the raw angle grows as it turns)
            [8:13]  qvel: block vx, vy, yaw rate, pusher vx, vy

        from (B, 10) states. Nothing absolute: nothing bounds the table, so the dynamics are the
        same anywhere. The goal is `system_metadata["mocap_pos"]` (nmocap, 3) and its heading
        "mocap_quat" (nmocap, 4) (each also (B, nmocap, ...)), else the model's own pose. A collect
        file stores obs/mocap_pos only; its goal's heading is the model's, since `reset` never turns
        the goal (only a GUI drag does), so the observation of a recorded step is this with
        system_metadata {"mocap_pos": that row}.
        """  # noqa: E501
        states = np.asarray(states, dtype=float)
        block, block_yaw, pusher = states[:, 0:2], states[:, 2], states[:, 3:5]
        goal = np.broadcast_to(
            mocap_pose(self.model, system_metadata, "mocap_pos")[..., 0, :2], block.shape
        )
        goal_yaw = yaw_of(mocap_pose(self.model, system_metadata, "mocap_quat")[..., 0, :])
        error = block_yaw - goal_yaw
        return np.column_stack(
            [
                goal - block,
                np.cos(error),
                np.sin(error),
                pusher - block,
                np.cos(block_yaw),
                np.sin(block_yaw),
                states[:, 5:],
            ]
        )

    def reset(self) -> None:
        """Block 0.15-0.25 m from the goal with a random heading; pusher at rest 0.2-0.3 m from the
        block."""
        mujoco.mj_resetData(self.sim_model, self.data)
        goal = self.data.mocap_pos[0, :2]
        block_direction, pusher_direction = self.rng.uniform(-np.pi, np.pi, 2)
        block = goal + self.rng.uniform(0.15, 0.25) * np.array(
            [np.cos(block_direction), np.sin(block_direction)]
        )
        pusher = block + self.rng.uniform(0.2, 0.3) * np.array(
            [np.cos(pusher_direction), np.sin(pusher_direction)]
        )
        self.data.qpos[:] = [*block, self.rng.uniform(-np.pi, np.pi), *pusher]
        mujoco.mj_forward(self.sim_model, self.data)

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Pusher-block friction x U[0.7, 1.3] per geom, the block's mass x U[0.8, 1.25], and the
        block's friction loss (the table's friction) x U[0.7, 1.3]."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)
        scale_body_mass(model, body_id(model, "block"), 0.8, 1.25, rng)
        dofs = [int(model.joint(name).dofadr[0]) for name in ("block_x", "block_y", "block_yaw")]
        scale_dof_frictionloss(model, dofs, 0.7, 1.3, rng)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """final_position_error (m) and final_angle_error (rad, absolute) of the block at the end;
        placed_fraction: share of the episode with both under 2 cm and 0.1 rad."""
        position_error, angle_error = self.errors(log.sensors)
        placed = (position_error < POSITION_TOLERANCE) & (np.abs(angle_error) < ANGLE_TOLERANCE)
        return {
            "final_position_error": float(position_error[-1]),
            "final_angle_error": float(abs(angle_error[-1])),
            "placed_fraction": float(placed.mean()),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: the block placed (within 2 cm and 0.1 rad) at the
        end."""
        return bool(
            metrics["final_position_error"] < POSITION_TOLERANCE
            and metrics["final_angle_error"] < ANGLE_TOLERANCE
        )
