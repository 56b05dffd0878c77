"""Planar walker: a torso on two three-link legs runs forward at a target speed without falling."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.norms import quadratic_norm, smooth_l1_norm
from judo.core.rollouts.randomize import contact_geom_ids, scale_geom_friction
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "walker.xml"
FALLEN_HEAD_HEIGHT = 0.9
"""Head height (m) below which `metrics` counts the walker as fallen."""


@slider("target_speed", 0.0, 4.0, 0.1)
@slider("target_head_height", 0.8, 1.8, 0.01)
@slider("w_speed", 0.0, 10.0, 0.1)
@slider("w_height", 0.0, 50.0, 0.1)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_control", 0.0, 1.0, 0.001)
@dataclass
class WalkerConfig(TaskConfig):
    """Walker reward weights and targets."""

    target_speed: float = 1.5
    """Forward speed (m/s) of the centre of mass to aim for."""
    target_head_height: float = 1.5
    """Head height (m) to stay above; standing straight puts the head at 1.67 m."""
    w_speed: float = 1.0
    """Weight on the centre of mass's forward speed differing from the target (m/s)."""
    w_height: float = 30.0
    """Weight on the head being below the target height (m)."""
    w_upright: float = 10.0
    """Weight on the torso leaning (1 - cos of its angle from vertical)."""
    w_control: float = 0.01
    """Weight on small joint torques."""


class Walker(Task[WalkerConfig]):
    """State [torso x, z offset, pitch, right and left hip, knee, ankle angles, and their
    velocities]; controls are the six joint torques, normalised to [-1, 1] (hips 100 Nm, knees 60
    Nm, ankles 20 Nm)."""

    measured_sensors = (
        *(
            f"{side}_{joint}_pos"
            for side in ("right", "left")
            for joint in ("hip", "knee", "ankle")
        ),
        "imu_quat",
        "imu_gyro",
        "imu_accel",
    )
    default_estimator = "ukf"
    """The UKF keeps 0.99 of the full-state forward speed with docs/estimation.md's sensing, the EKF
    0.48 (docs/estimation.md)."""
    lower_is_better = ("fallen_fraction",)
    focus_body = "torso"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._head_column = self.get_sensor_start_index("trace_head")
        self._up_column = self.get_sensor_start_index("torso_up")
        self._velocity_column = self.get_sensor_start_index("center_of_mass_velocity")
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: WalkerConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        head_height = sensors[..., self._head_column + 2]
        torso_up = sensors[..., self._up_column + 2]
        forward_speed = sensors[..., self._velocity_column]
        too_low = np.maximum(config.target_head_height - head_height, 0.0)
        return -(
            config.w_speed
            * smooth_l1_norm((forward_speed - config.target_speed)[..., None], 0.2).sum(-1)
            + config.w_height * too_low.sum(-1)
            + config.w_upright * (1.0 - torso_up).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def reset(self) -> None:
        """Standing, with joint angles and velocities jittered a little."""
        mujoco.mj_resetData(self.sim_model, self.data)
        self.data.qpos[3:] = self.rng.uniform(-0.1, 0.1, 6)
        self.data.qvel[:] = self.rng.normal(0.0, 0.1, self.sim_model.nv)
        mujoco.mj_forward(self.sim_model, self.data)

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.7, 1.3] (its own draw): the feet's grip on the
        floor."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """mean_forward_speed: torso travel (m) over the episode's duration (s); fallen_fraction:
        share of the episode with the head below 0.9 m; final_head_height (m)."""
        head_height = log.sensors[:, self._head_column + 2]
        duration = log.times[-1] - log.times[0] + self.sim_model.opt.timestep
        return {
            "mean_forward_speed": float((log.states[-1, 0] - log.states[0, 0]) / duration),
            "fallen_fraction": float(np.mean(head_height < FALLEN_HEAD_HEIGHT)),
            "final_head_height": float(head_height[-1]),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: never fallen."""
        return bool(metrics["fallen_fraction"] == 0.0)
