"""Particle: push a point mass with x/y forces onto a goal that moves to a new spot each time it is
reached."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.model import mocap_pose
from judo.core.norms import quadratic_norm, smooth_l1_norm
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "particle.xml"
GOAL_SPAN = 0.45
"""New goals are drawn uniformly from the square [-GOAL_SPAN, GOAL_SPAN]^2 (m), inside the walls."""


@slider("w_position", 0.0, 20.0, 0.1)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.01)
@slider("goal_radius", 0.005, 0.2, 0.005)
@dataclass
class ParticleConfig(TaskConfig):
    """Particle reward weights and goal rule. The goal itself is the mocap body "goal": drag it in
    the GUI."""

    w_position: float = 5.0
    """Weight on the distance (m) from the particle to the goal."""
    w_velocity: float = 0.1
    """Weight on a slow particle, so it stops on the goal instead of overshooting."""
    w_control: float = 0.01
    """Weight on small forces."""
    goal_radius: float = 0.03
    """Distance (m) within which the goal counts as reached."""
    new_goal_on_reach: bool = True
    """Move the goal to a random spot whenever the particle reaches it (turn off to place goals by
    hand)."""


class Particle(Task[ParticleConfig]):
    """State [x, y, vx, vy] of the particle; controls are the x, y forces (2 N at 1).

    The goal is a mocap body; the planner reads it through the "goal_position" sensor.
    """

    measured_sensors = ("x_pos", "y_pos")
    lower_is_better = ("final_distance",)
    focus_body = "particle"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._particle_column = self.get_sensor_start_index("trace_particle")
        self._goal_column = self.get_sensor_start_index("goal_position")
        self.reset()

    def _positions(self, sensors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(..., 2) particle and goal x, y from (..., nsensordata) sensor rows."""
        particle, goal = self._particle_column, self._goal_column
        return sensors[..., particle : particle + 2], sensors[..., goal : goal + 2]

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: ParticleConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        particle, goal = self._positions(sensors)
        return -(
            config.w_position * smooth_l1_norm(particle - goal, 0.02).sum(-1)
            + config.w_velocity * quadratic_norm(states[..., 2:4]).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 6) [x, y, vx, vy, goal x - x, goal y - y]: the (B, 4) state and the goal relative to the particle.

        The goal is the mocap body's position, `system_metadata["mocap_pos"]` (nmocap, 3) or (B,
        nmocap, 3) (a collect file's obs/mocap_pos, reshaped), else the model's own; without it a
        policy could not know where to go. The position itself stays in: the walls make the dynamics
        depend on where the particle is.
        """  # noqa: E501
        states = np.asarray(states, dtype=float)
        goal = np.broadcast_to(
            mocap_pose(self.model, system_metadata, "mocap_pos")[..., 0, :2], (len(states), 2)
        )
        return np.concatenate([states, goal - states[:, :2]], axis=1)

    def reset(self) -> None:
        """Particle at rest on a random spot; a random goal."""
        mujoco.mj_resetData(self.sim_model, self.data)
        self.data.qpos[:] = self.rng.uniform(-GOAL_SPAN, GOAL_SPAN, 2)
        self._new_goal()

    def _new_goal(self) -> None:
        self.data.mocap_pos[0, :2] = self.rng.uniform(-GOAL_SPAN, GOAL_SPAN, 2)
        mujoco.mj_forward(self.sim_model, self.data)

    def pre_sim_step(self) -> None:
        """Draw a new goal once the particle is within `goal_radius` of the current one."""
        if self.config.new_goal_on_reach:
            distance = np.linalg.norm(self.data.qpos[:2] - self.data.mocap_pos[0, :2])
            if distance < self.config.goal_radius:
                self._new_goal()

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """goals_reached: how often the goal moved on (it moves when reached); goals_per_minute over
        the episode; final_distance (m) from the particle to the last goal."""
        particle, goal = self._positions(log.sensors)
        goals = int(np.count_nonzero(np.any(np.diff(goal, axis=0) != 0.0, axis=-1)))
        duration = log.times[-1] - log.times[0] + self.sim_model.opt.timestep
        return {
            "goals_reached": float(goals),
            "goals_per_minute": float(60.0 * goals / duration),
            "final_distance": float(np.linalg.norm(particle[-1] - goal[-1])),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: at least one goal reached."""
        return bool(metrics["goals_reached"] >= 1)
