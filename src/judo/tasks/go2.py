"""Unitree Go2: stand up from lying and hold a height under pushes (go2_stand), or walk to a velocity command
(go2_walk), planned directly in the 12 motor position targets the robot's own PD tracks.

The model (models/unitree_go2/, from MuJoCo Menagerie) keeps to the contract the Unitree bridge reads
(judo.unitree): actuators in Unitree's motor order, position actuators carrying kp / kd, and the measured
sensors rt/lowstate carries. The rewards reuse the quadruped task's gait schedule (judo.tasks.quadruped).
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from judo.core.fields import slider
from judo.core.randomize import contact_geom_ids, scale_geom_friction
from judo.core.task import ConfigT, EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "unitree_go2" / "scene.xml"
LEGS = ("FR", "FL", "RR", "RL")
"""The legs in Unitree's motor order: front right, front left, rear right, rear left."""
JOINTS = tuple(f"{leg}_{part}_joint" for leg in LEGS for part in ("hip", "thigh", "calf"))
"""The 12 joints in motor order (motors 0..11)."""
FOOT_RADIUS = 0.022
"""Radius (m) of the foot spheres: a foot on the floor has its site this high."""
STAND_POSE = np.tile([0.0, 0.9, -1.8], 4)
"""(12,) the crouched stand's joint targets (keyframe "home", base 0.25 m up): the safe action."""
STANDING_FRACTION_OF_TARGET = 0.8
"""The base counts as standing above this share of the target height, upright within UPRIGHT_COS."""
UPRIGHT_COS = np.cos(np.deg2rad(30.0))
"""The base counts as upright while its z axis is within 30 degrees of vertical."""
FALLEN_HEIGHT = 0.15
"""Base height (m) under which a robot that stood counts as fallen (lying, it is 0.096 m)."""
STAND_HOLD_TIME = 1.0
"""Seconds the base must stay standing for `time_to_stand` to count it as up."""


@slider("target_height", 0.15, 0.38, 0.005)
@slider("push_force", 0.0, 150.0, 1.0)
@slider("push_interval", 0.5, 10.0, 0.5)
@slider("w_height", 0.0, 1000.0, 1.0)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_balance", 0.0, 100.0, 0.1)
@slider("w_velocity", 0.0, 20.0, 0.1)
@slider("w_posture", 0.0, 5.0, 0.01)
@slider("w_effort", 0.0, 1.0, 0.001)
@dataclass
class Go2StandConfig(TaskConfig):
    """What go2_stand weighs: height, uprightness, balance over the feet, base motion, posture and effort; and
    the pushes the plant gets."""

    target_height: float = 0.30
    """Base height (m) to hold; the crouched stand puts it at 0.25 m, Unitree's stand pose at 0.333 m."""
    push_force: float = 40.0
    """Horizontal force (N) of each push on the base, in a random direction (0: no pushes). Plant only."""
    push_interval: float = 3.0
    """Seconds of sim time between pushes; each lasts 0.1 s (40 N: a 4 N s shove, about 0.27 m/s on 15 kg)."""
    w_height: float = 400.0
    """Weight on the base height error (squared, m^2)."""
    w_upright: float = 20.0
    """Weight on the base tilting (1 - cos of its angle from vertical)."""
    w_balance: float = 20.0
    """Weight on the base's horizontal offset from the middle of the four feet (squared, m^2)."""
    w_velocity: float = 1.0
    """Weight on the base's linear and angular speed (squared, m^2/s^2 and rad^2/s^2): come to rest."""
    w_posture: float = 0.1
    """Weight on the joint angles differing from the crouched stand (squared, summed, rad^2)."""
    w_effort: float = 0.01
    """Weight on the joint torques the PD spends, as a share of the motor limit (squared, summed)."""


class Go2Base(Task[ConfigT]):
    """What both Go2 tasks share: the model, its sensor columns, the reward's common terms, pushes and falls.

    State [base position (3), quaternion (4), 12 joint angles, base velocity (6), 12 joint velocities]; the 12
    controls are motor position targets q_des (rad) in Unitree's motor order, which the robot's PD tracks.
    """

    focus_body = "base"
    lower_is_better: ClassVar[tuple[str, ...]] = ("falls", "time_to_stand")
    measured_sensors = (
        *(f"{joint}_pos" for joint in JOINTS),
        *(f"{joint}_vel" for joint in JOINTS),
        "imu_quat",
        "imu_gyro",
        "imu_acc",
        *(f"foot_force_{leg}" for leg in LEGS),
    )
    """What rt/lowstate carries: 12 encoders, 12 joint speeds, the base IMU (orientation, gyro, accelerometer) and
    the four foot contact forces (N)."""
    default_estimator = "ekf"
    start_key: ClassVar[str] = "lying"
    """The keyframe `reset` starts the plant from."""

    def __init__(self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None) -> None:
        super().__init__(model_path, sim_model_path)
        self._joint_qpos = np.array([self.get_joint_position_start_index(j) for j in JOINTS])
        self._base = self.get_sensor_start_index("trace_base")
        self._feet = np.array([self.get_sensor_start_index(f"trace_{leg}_foot") for leg in LEGS])
        self._up = self.get_sensor_start_index("base_up")
        self._forward = self.get_sensor_start_index("base_forward")
        self._velocity = self.get_sensor_start_index("base_world_velocity")
        self._angvel = self.get_sensor_start_index("base_world_angvel")
        self._clock = self.get_sensor_start_index("clock")
        self._torque_per_rad = self.model.actuator_gainprm[:, 0] / np.abs(self.model.actuator_forcerange[:, 1])
        self._base_body = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_BODY, "base")
        self._next_push = 0.0
        self._push_until = -1.0
        self.reset()

    def base_height(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the base height (m) from (..., nsensordata) sensor rows."""
        return sensors[..., self._base + 2]

    def heading(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the base's yaw (rad) from (..., nsensordata) sensor rows."""
        return np.arctan2(sensors[..., self._forward + 1], sensors[..., self._forward])

    def body_velocity(self, sensors: np.ndarray) -> np.ndarray:
        """(..., 3) [forward, left, yaw rate] of the base in its heading frame (m/s, m/s, rad/s) from (...,
        nsensordata) sensor rows: the frame a velocity command is given in."""
        yaw = self.heading(sensors)
        vx, vy = sensors[..., self._velocity], sensors[..., self._velocity + 1]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.stack([c * vx + s * vy, -s * vx + c * vy, sensors[..., self._angvel + 2]], axis=-1)

    def base_cost(self, states: np.ndarray, sensors: np.ndarray, controls: np.ndarray, config: Any) -> np.ndarray:
        """(num_rollouts, T) the per-step cost of height, tilt, balance over the feet, posture and effort from
        (num_rollouts, T, nq + nv) states, (num_rollouts, T, nsensordata) sensors and (num_rollouts, T, 12)
        controls."""
        height_error = self.base_height(sensors) - config.target_height
        tilt = 1.0 - sensors[..., self._up + 2]
        feet_xy = sensors[..., self._feet[:, None] + np.arange(2)].mean(-2)  # (num_rollouts, T, 2)
        offset = sensors[..., self._base : self._base + 2] - feet_xy
        joints = states[..., self._joint_qpos]
        torque_share = (controls - joints) * self._torque_per_rad
        return (
            config.w_height * np.square(height_error)
            + config.w_upright * tilt
            + config.w_balance * np.square(offset).sum(-1)
            + config.w_posture * np.square(joints - STAND_POSE).sum(-1)
            + config.w_effort * np.square(torque_share).sum(-1)
        )

    def reset(self) -> None:
        """At rest in the `start_key` keyframe at the origin; the first push one interval away."""
        key = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_KEY, self.start_key)
        mujoco.mj_resetDataKeyframe(self.sim_model, self.data, key)
        mujoco.mj_forward(self.sim_model, self.data)
        self._next_push = float(getattr(self.config, "push_interval", 0.0))
        self._push_until = -1.0

    def pre_sim_step(self) -> None:
        """Push the base: every `push_interval` s of sim time, `push_force` N horizontally in a random direction
        for 0.1 s (through xfrc_applied, which only the plant has)."""
        config: Any = self.config
        force = self.data.xfrc_applied[self._base_body]
        now = self.data.time
        if config.push_force > 0.0 and now >= self._next_push:
            angle = self.rng.uniform(-np.pi, np.pi)
            force[:2] = config.push_force * np.array([np.cos(angle), np.sin(angle)])
            self._push_until = now + 0.1
            self._next_push = now + config.push_interval
        elif now >= self._push_until:
            force[:] = 0.0

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(12,) the crouched stand's joint targets: with no noise, the plan stands up."""
        return STAND_POSE.copy()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(12,) the crouched stand's joint targets (0, 0.9, -1.8 per leg), whatever the `state`. Holding the
        current joint angles, the default for position actuators, freezes a falling robot mid-fall; the crouch has
        a low centre of mass, feet under the hips, and is where the PD holds a standing robot up without help."""
        return STAND_POSE.copy()

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.7, 1.3] (its own draw): the feet's grip on the floor."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)

    def standing(self, sensors: np.ndarray) -> np.ndarray:
        """(T,) whether the base is up (above STANDING_FRACTION_OF_TARGET of the target height) and upright, from
        (T, nsensordata) sensor rows."""
        config: Any = self.config
        up = self.base_height(sensors) > STANDING_FRACTION_OF_TARGET * config.target_height
        return up & (sensors[..., self._up + 2] > UPRIGHT_COS)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """standing_fraction: share of the episode standing (`standing`); time_to_stand: when (s) the base first
        stood and stayed so for STAND_HOLD_TIME, or the episode's length if never; falls: times the base, having
        stood, dropped below FALLEN_HEIGHT or tilted past 60 degrees; final_height (m)."""
        standing = self.standing(log.sensors)
        dt = float(self.sim_model.opt.timestep)
        hold = max(1, round(STAND_HOLD_TIME / dt))
        held = np.convolve(standing, np.ones(hold), mode="valid") == hold
        start = int(np.argmax(held)) if held.any() else len(standing) - 1
        down = (self.base_height(log.sensors) < FALLEN_HEIGHT) | (log.sensors[:, self._up + 2] < 0.5)
        falls, stood = 0, False
        for is_up, is_down in zip(standing, down, strict=True):
            if is_up:
                stood = True
            elif stood and is_down:
                falls, stood = falls + 1, False
        return {
            "standing_fraction": float(standing.mean()),
            "time_to_stand": float(log.times[start] - log.times[0] + dt),
            "falls": float(falls),
            "final_height": float(self.base_height(log.sensors[-1])),
        }


class Go2Stand(Go2Base[Go2StandConfig]):
    """Stand up from Unitree's stand-down pose (lying on folded legs) and hold the base at `target_height`, level
    and over the feet, while the plant pushes the base every `push_interval` s."""

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: Go2StandConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,): `base_cost` and the base's speed."""
        speed = np.square(sensors[..., self._velocity : self._velocity + 3]).sum(-1)
        spin = np.square(sensors[..., self._angvel : self._angvel + 3]).sum(-1)
        cost = self.base_cost(states, sensors, controls, config) + config.w_velocity * (speed + spin)
        return -cost.mean(-1)
