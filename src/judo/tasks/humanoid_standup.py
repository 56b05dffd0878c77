"""Humanoid stand-up: a 3-D humanoid lying on its back gets up and stands still."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.norms import quadratic_norm, smooth_l1_norm
from judo.core.rollouts.randomize import contact_geom_ids, scale_geom_friction
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "humanoid_standup.xml"
STANDING_HEAD_HEIGHT = 1.2
"""Head height (m) above which `metrics` counts the humanoid as standing (upright, it is 1.40 m)."""
GRAVITY = 9.81
"""Gravity (m/s^2) used for the capture point."""
STAND_HOLD_TIME = 1.0
"""Seconds the head must stay above STANDING_HEAD_HEIGHT for `metrics` to count the humanoid as
up."""


@slider("target_head_height", 0.5, 1.5, 0.01)
@slider("w_height", 0.0, 50.0, 0.1)
@slider("w_upright", 0.0, 20.0, 0.1)
@slider("w_balance", 0.0, 20.0, 0.1)
@slider("w_posture", 0.0, 5.0, 0.01)
@slider("w_velocity", 0.0, 5.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.001)
@dataclass
class HumanoidStandupConfig(TaskConfig):
    """Humanoid stand-up reward weights and target."""

    target_head_height: float = 1.35
    """Head height (m) to rise to; standing straight puts the head at 1.40 m."""
    w_height: float = 10.0
    """Weight on the head's distance (m) from the target height; above it counts too, so jumping
    does not pay."""
    w_upright: float = 2.0
    """Weight on the torso leaning (1 - cos of its angle from vertical)."""
    w_balance: float = 5.0
    """Weight on the horizontal distance (m) from the capture point (the centre of mass moved on by
    its velocity times sqrt(height / g)) to the midpoint of the feet."""
    w_posture: float = 0.1
    """Weight on the joint angles (rad) differing from the straight standing pose."""
    w_velocity: float = 1.0
    """Weight on the centre of mass's horizontal speed (m/s), so it comes to rest once up."""
    w_control: float = 0.01
    """Weight on small joint torques."""


class HumanoidStandup(Task[HumanoidStandupConfig]):
    """State [torso position, quaternion, 16 joint angles, and the 22 velocities]; controls are the
    16 joint torques, normalised to [-1, 1] (from 40 Nm at the elbows to 150 Nm at the hips)."""

    lower_is_better = ("time_to_stand",)
    focus_body = "torso"
    measured_sensors = (
        *(
            f"{joint}_pos"
            for joint in (
                "abdomen_pitch",
                "abdomen_roll",
                *(
                    f"{side}_{j}"
                    for side in ("right", "left")
                    for j in ("hip_roll", "hip_pitch", "knee", "ankle")
                ),
                *(
                    f"{side}_{j}"
                    for side in ("right", "left")
                    for j in ("shoulder_pitch", "shoulder_roll", "elbow")
                ),
            )
        ),
        "imu_quat",
        "imu_gyro",
        "imu_accel",
    )

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._columns = {
            name: self.get_sensor_start_index(name)
            for name in (
                "trace_head",
                "trace_right_foot",
                "trace_left_foot",
                "torso_up",
                "center_of_mass",
                "center_of_mass_velocity",
            )
        }
        self.reset()

    def head_height(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) head height (m) from (..., nsensordata) sensor rows."""
        return sensors[..., self._columns["trace_head"] + 2]

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: HumanoidStandupConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        c = self._columns
        height_error = smooth_l1_norm(
            (self.head_height(sensors) - config.target_head_height)[..., None], 0.05
        )
        torso_up = sensors[..., c["torso_up"] + 2]
        feet_middle = 0.5 * (
            sensors[..., c["trace_right_foot"] : c["trace_right_foot"] + 2]
            + sensors[..., c["trace_left_foot"] : c["trace_left_foot"] + 2]
        )
        com = sensors[..., c["center_of_mass"] : c["center_of_mass"] + 3]
        com_velocity = sensors[..., c["center_of_mass_velocity"] : c["center_of_mass_velocity"] + 2]
        # Capture point: where the centre of mass would come to rest over, as for an inverted
        # pendulum.
        capture_point = com[..., :2] + com_velocity * np.sqrt(
            np.maximum(com[..., 2:3], 0.0) / GRAVITY
        )
        return -(
            config.w_height * height_error.sum(-1)
            + config.w_upright * (1.0 - torso_up).sum(-1)
            + config.w_balance * smooth_l1_norm(capture_point - feet_middle, 0.05).sum(-1)
            + config.w_posture * quadratic_norm(states[..., 7 : self.model.nq]).sum(-1)
            + config.w_velocity * quadratic_norm(com_velocity).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def reset(self) -> None:
        """Lying on its back, facing up, with a random heading and jittered joints, then settled on
        the floor."""
        mujoco.mj_resetData(self.sim_model, self.data)
        heading = self.rng.uniform(-np.pi, np.pi)
        # pitch -90 deg: face up
        back_down = np.array([np.cos(-np.pi / 4), 0.0, np.sin(-np.pi / 4), 0.0])
        turn = np.array([np.cos(heading / 2), 0.0, 0.0, np.sin(heading / 2)])
        quaternion = np.zeros(4)
        mujoco.mju_mulQuat(quaternion, turn, back_down)
        self.data.qpos[:3] = [0.0, 0.0, 0.2]
        self.data.qpos[3:7] = quaternion
        low, high = self.sim_model.jnt_range[1:].T
        self.data.qpos[7:] = np.clip(self.rng.uniform(-0.1, 0.1, self.sim_model.nq - 7), low, high)
        for _ in range(100):  # let it settle onto the floor, limp
            mujoco.mj_step(self.sim_model, self.data)
        self.data.time = 0.0
        mujoco.mj_forward(self.sim_model, self.data)

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.7, 1.3] (its own draw): the body's grip on the
        floor."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """final_head_height (m); standing_fraction: share of the episode with the head above 1.2 m;
        time_to_stand: when (s) the head first rose above 1.2 m to stay there for at least 1 s (a
        hop does not count), or the episode's length if it never did; standing_after_up: share of
        the time from then on with the head above 1.2 m (0 if it never stood)."""
        head = self.head_height(log.sensors)
        standing = head > STANDING_HEAD_HEIGHT
        dt = self.sim_model.opt.timestep
        hold = max(1, round(STAND_HOLD_TIME / dt))
        # held[i]: standing through i..i+hold-1
        held = np.convolve(standing, np.ones(hold), mode="valid") == hold
        start = int(np.argmax(held)) if held.any() else len(head) - 1
        return {
            "final_head_height": float(head[-1]),
            "standing_fraction": float(standing.mean()),
            "time_to_stand": float(log.times[start] - log.times[0] + dt),
            "standing_after_up": float(standing[start:].mean()) if held.any() else 0.0,
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: stood up and then stayed standing at least 90% of
        the time."""
        return bool(metrics["standing_after_up"] >= 0.9)
