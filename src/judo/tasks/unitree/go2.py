"""Unitree Go2: stand up from lying and hold a height under pushes (go2_stand), or walk to a
velocity command (go2_walk), planned directly in the 12 motor position targets the robot's own PD
tracks.

The model (models/unitree_go2/, from MuJoCo Menagerie) keeps to the contract the Unitree bridge
reads (judo.unitree): actuators in Unitree's motor order, position actuators carrying kp / kd, and
the measured sensors rt/lowstate carries. The rewards reuse the quadruped task's gait schedule
(judo.tasks.gait); go2_walk's optimizer samples among a trot gait policy's candidates by default.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import mujoco
import numpy as np

from judo.core.configuration.fields import np_1d_field, slider
from judo.core.policy import Policy, PolicyError
from judo.core.rollouts.randomize import contact_geom_ids, scale_geom_friction
from judo.core.task import EpisodeLog, Task, TaskConfig
from judo.tasks.gait import GaitName, gait_of, swing_heights
from judo.tasks.gait_policy import GaitPolicy
from judo.tasks.quadruped import locomotion_features
from judo.tasks.quadruped_velocity import AVERAGE_WINDOW, trailing_mean
from judo.tasks.unitree.pushes import RandomPushes

MODEL_PATH = Path(__file__).parents[1] / "models" / "unitree_go2" / "scene.xml"
LEGS = ("FR", "FL", "RR", "RL")
"""The legs in Unitree's motor order: front right, front left, rear right, rear left."""
JOINTS = tuple(f"{leg}_{part}_joint" for leg in LEGS for part in ("hip", "thigh", "calf"))
"""The 12 joints in motor order (motors 0..11)."""
FOOT_RADIUS = 0.022
"""Radius (m) of the foot spheres: a foot on the floor has its site this high."""
STAND_POSE = np.tile([0.0, 0.9, -1.8], 4)
"""(12,) the crouched stand's joint targets (keyframe "home", base 0.25 m up): the safe action."""
RISE_POSE = np.tile([0.0, 0.8, -1.5], 4)
"""(12,) targets the PD holds the base at about 0.30 m with (the default target): the warm start."""
POSTURE = np.tile([0.0, 0.8, -1.6], 4)
"""(12,) the angles it stands at under RISE_POSE (calves sag 0.09 rad): the reward's posture."""
STANDING_FRACTION_OF_TARGET = 0.8
"""The base counts as standing above this share of the target height, upright within UPRIGHT_COS."""
UPRIGHT_COS = np.cos(np.deg2rad(30.0))
"""The base counts as upright while its z axis is within 30 degrees of vertical."""
FALLEN_HEIGHT = 0.15
"""Base height (m) under which a robot that stood counts as fallen (lying, it is 0.096 m)."""
STAND_HOLD_TIME = 1.0
"""Seconds the base must stay standing for `time_to_stand` to count it as up."""
OBSERVATION = (
    "12 joint angles minus POSTURE (rad), 12 joint velocities (rad/s), base angular velocity in "
    "the base frame (3, rad/s, what the IMU's gyro reads), gravity's direction in the base frame "
    "(3), the command [vx, vy, yaw rate] (3), the gait clock [cos, sin] of 2 pi 2.5 Hz t (2)"
)
"""What `Go2Walk.policy_observation` holds: 35 values, in quadruped_velocity.OBSERVATION's order."""
POLICY_PATH = Path(__file__).parents[1] / "models" / "policies" / "go2_trot.json"
"""go2_walk's default proposal policy: a trot (`python -m judo gait-search --task go2_walk`)."""


@slider("target_height", 0.15, 0.38, 0.005)
@slider("push_force", 0.0, 150.0, 1.0)
@slider("push_interval", 0.5, 10.0, 0.1)
@slider("push_duration", 0.02, 1.0, 0.01)
@slider("w_height", 0.0, 1000.0, 1.0)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_balance", 0.0, 100.0, 0.1)
@slider("w_posture", 0.0, 5.0, 0.01)
@slider("w_effort", 0.0, 1.0, 0.001)
@dataclass
class Go2BaseConfig(TaskConfig):
    """What both Go2 tasks weigh (height, uprightness, balance over the feet, posture, effort) and
    the pushes the plant gets."""

    target_height: float = 0.30
    """Base height (m) to hold; the crouched stand puts it at 0.25 m, Unitree's stand at 0.333 m."""
    push_force: float = 40.0
    """Horizontal force (N) of each push on the plant's base, in a random direction; 0 turns pushes
    off."""
    push_interval: float = 3.0
    """Seconds between pushes (the first comes this long after a reset); read at each reset."""
    push_duration: float = 0.1
    """Seconds each push lasts (40 N for 0.1 s gives the 15 kg robot about 0.27 m/s)."""
    w_height: float = 400.0
    """Weight on the base height error (squared, m^2)."""
    w_upright: float = 20.0
    """Weight on the base tilting (1 - cos of its angle from vertical)."""
    w_balance: float = 20.0
    """Weight on the base's horizontal offset from the middle of the four feet (squared, m^2)."""
    w_posture: float = 0.1
    """Weight on the joint angles differing from POSTURE, the stand at 0.30 m (squared, summed,
    rad^2)."""
    w_effort: float = 0.01
    """Weight on the joint torques the PD spends, as a share of the motor limit (squared,
    summed)."""


@slider("w_velocity", 0.0, 20.0, 0.1)
@dataclass
class Go2StandConfig(Go2BaseConfig):
    """go2_stand: the common weights and the base's motion, which standing still should not have."""

    w_velocity: float = 1.0
    """Weight on the base's linear and angular speed (squared, m^2/s^2, rad^2/s^2): come to rest."""


@slider("step_height", 0.0, 0.15, 0.005)
@slider("w_gait", 0.0, 1000.0, 1.0)
@slider("w_velocity", 0.0, 20.0, 0.1)
@slider("w_yaw_rate", 0.0, 10.0, 0.1)
@dataclass
class Go2WalkConfig(Go2BaseConfig):
    """go2_walk: the common weights, a gait schedule and the velocity command to track (in the
    base's heading frame). Pushes are off unless asked for."""

    velocity_command: np.ndarray = np_1d_field(
        [0.5, 0.0, 0.0],
        names=["vx", "vy", "yaw_rate"],
        mins=[-1.0, -0.6, -1.5],
        maxs=[1.5, 0.6, 1.5],
        steps=[0.05, 0.05, 0.05],
    )
    """(3,) the command [forward (m/s), left (m/s), yaw rate (rad/s, counter-clockwise)] in the
    heading frame; `--task-config.velocity-command 0.5 0 0` on the command line, `velocity_command =
    [0.5, 0, 0]` in TOML."""
    gait: GaitName = "trot"
    """The foot schedule (judo.tasks.gait.GAITS): "trot", "walk" or "stand" (no foot lifts)."""
    step_height: float = 0.06
    """How high (m) a swinging foot is lifted at mid-swing."""
    push_force: float = 0.0
    """Horizontal force (N) of each push on the plant's base; 0 (the default here): no pushes."""
    w_height: float = 800.0
    """Weight on the base height error (squared, m^2): twice go2_stand's (else the trot: 0.24 m)."""
    w_balance: float = 0.0
    """Weight on the base's offset from the middle of the feet: none while walking (strides)."""
    w_gait: float = 100.0
    """Weight on each foot's height differing from the gait's schedule (squared, summed, m^2)."""
    w_velocity: float = 6.0
    """Weight on the base's horizontal velocity differing from the command's (squared, m^2/s^2)."""
    w_yaw_rate: float = 2.0
    """Weight on the base's yaw rate differing from the command's (squared, rad^2/s^2)."""


Go2ConfigT = TypeVar("Go2ConfigT", bound=Go2BaseConfig)


class Go2Base(Task[Go2ConfigT]):
    """What both Go2 tasks share: the model, its sensor columns, the reward's common terms, pushes
    and falls.

    State [base position (3), quaternion (4), 12 joint angles, base velocity (6), 12 joint
    velocities]; the 12 controls are motor position targets q_des (rad) in Unitree's motor order,
    which the robot's PD tracks.
    """

    focus_body = "base"
    lower_is_better: ClassVar[tuple[str, ...]] = ("falls", "time_to_stand", "height_error")
    check_latency_ms: ClassVar[float] = 20.0
    measured_sensors = (
        *(f"{joint}_pos" for joint in JOINTS),
        *(f"{joint}_vel" for joint in JOINTS),
        "imu_quat",
        "imu_gyro",
        "imu_acc",
        *(f"foot_force_{leg}" for leg in LEGS),
    )
    """What rt/lowstate carries: 12 encoders, 12 joint speeds, the base IMU (orientation, gyro,
    accelerometer) and the four foot contact forces (N)."""
    default_estimator = "legged"
    """Over Unitree's wire it stands and walks the Go2 where the EKF fell (docs/hardware.md)."""
    start_key: ClassVar[str] = "lying"
    """The keyframe `reset` starts the plant from."""

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._joint_qpos = np.array([self.get_joint_position_start_index(j) for j in JOINTS])
        self._base = self.get_sensor_start_index("trace_base")
        self._feet = np.array([self.get_sensor_start_index(f"trace_{leg}_foot") for leg in LEGS])
        self._up = self.get_sensor_start_index("base_up")
        self._forward = self.get_sensor_start_index("base_forward")
        self._velocity = self.get_sensor_start_index("base_world_velocity")
        self._angvel = self.get_sensor_start_index("base_world_angvel")
        self._clock = self.get_sensor_start_index("clock")
        self._torque_per_rad = self.model.actuator_gainprm[:, 0] / np.abs(
            self.model.actuator_forcerange[:, 1]
        )
        self.pushes = RandomPushes(self.sim_model, "base")
        self.reset()

    def base_height(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the base height (m) from (..., nsensordata) sensor rows."""
        return sensors[..., self._base + 2]

    def heading(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the base's yaw (rad) from (..., nsensordata) sensor rows."""
        return np.arctan2(sensors[..., self._forward + 1], sensors[..., self._forward])

    def body_velocity(self, sensors: np.ndarray) -> np.ndarray:
        """(..., 3) [forward, left, yaw rate] of the base in its heading frame (m/s, m/s, rad/s)
        from (..., nsensordata) sensor rows: the frame a velocity command is given in."""
        yaw = self.heading(sensors)
        vx, vy = sensors[..., self._velocity], sensors[..., self._velocity + 1]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.stack(
            [c * vx + s * vy, -s * vx + c * vy, sensors[..., self._angvel + 2]], axis=-1
        )

    def base_cost(
        self, states: np.ndarray, sensors: np.ndarray, controls: np.ndarray, config: Go2BaseConfig
    ) -> np.ndarray:
        """(num_rollouts, T) the per-step cost of height, tilt, balance over the feet, posture and
        effort from (num_rollouts, T, nq + nv) states, (num_rollouts, T, nsensordata) sensors and
        (num_rollouts, T, 12) controls."""
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
            + config.w_posture * np.square(joints - POSTURE).sum(-1)
            + config.w_effort * np.square(torque_share).sum(-1)
        )

    def reset(self) -> None:
        """At rest in the `start_key` keyframe at the origin, facing +x; the first push one interval
        away."""
        key = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_KEY, self.start_key)
        mujoco.mj_resetDataKeyframe(self.sim_model, self.data, key)
        mujoco.mj_forward(self.sim_model, self.data)
        self.pushes.reset(self.config.push_interval)

    def pre_sim_step(self) -> None:
        """Push the plant's base when a push is due (config.push_force, push_interval,
        push_duration)."""
        config = self.config
        self.pushes.apply(
            self.data, self.rng, config.push_force, config.push_interval, config.push_duration
        )

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(12,) RISE_POSE: with no noise, the plan stands up to about the default target height."""
        return RISE_POSE.copy()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(12,) the crouched stand's joint targets (0, 0.9, -1.8 per leg), whatever the `state`.
        Holding the current joint angles, the default for position actuators, freezes a falling
        robot mid-fall; the crouch has a low centre of mass, feet under the hips, and is where the
        PD holds a standing robot up without help."""
        return STAND_POSE.copy()

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.7, 1.3] (its own draw): the feet's grip on the
        floor."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)

    def standing(self, sensors: np.ndarray) -> np.ndarray:
        """(T,) whether the base is up (above STANDING_FRACTION_OF_TARGET of the target height) and
        upright, from (T, nsensordata) sensor rows."""
        up = self.base_height(sensors) > STANDING_FRACTION_OF_TARGET * self.config.target_height
        return up & (sensors[..., self._up + 2] > UPRIGHT_COS)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """standing_fraction: share of the episode standing (`standing`); time_to_stand: when (s)
        the base first stood and stayed so for STAND_HOLD_TIME, or the episode's length if never;
        falls: times the base, having stood, dropped below FALLEN_HEIGHT or tilted past 60 degrees;
        height_error: mean absolute distance (m) of the base from the target height from
        time_to_stand on (the target itself if it never stood); final_height (m); pushes given."""
        standing = self.standing(log.sensors)
        dt = float(self.sim_model.opt.timestep)
        hold = max(1, round(STAND_HOLD_TIME / dt))
        held = np.convolve(standing, np.ones(hold), mode="valid") == hold
        start = int(np.argmax(held)) if held.any() else len(standing) - 1
        down = (self.base_height(log.sensors) < FALLEN_HEIGHT) | (
            log.sensors[:, self._up + 2] < 0.5
        )
        falls, stood = 0, False
        for is_up, is_down in zip(standing, down, strict=True):
            if is_up:
                stood = True
            elif stood and is_down:
                falls, stood = falls + 1, False
        after = self.base_height(log.sensors[start:]) - self.config.target_height
        return {
            "standing_fraction": float(standing.mean()),
            "height_error": float(np.abs(after).mean())
            if held.any()
            else float(self.config.target_height),
            "time_to_stand": float(log.times[start] - log.times[0] + dt),
            "falls": float(falls),
            "final_height": float(self.base_height(log.sensors[-1])),
            "pushes": float(self.pushes.count),
        }


class Go2Stand(Go2Base[Go2StandConfig]):
    """Stand up from Unitree's stand-down pose (lying on folded legs) and hold the base at
    `target_height`, level and over the feet, while the plant pushes the base every `push_interval`
    s."""

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
        cost = self.base_cost(states, sensors, controls, config) + config.w_velocity * (
            speed + spin
        )
        return -cost.mean(-1)


class Go2Walk(Go2Base[Go2WalkConfig]):
    """Track `velocity_command` [vx, vy, yaw rate] in the base's heading frame from the crouched
    stand, lifting the feet on the gait's schedule (the model's "clock" sensor places each rollout
    step in the stride). `policy_path`: the default proposal policy's JSON file, or None: none."""

    start_key = "home"
    lower_is_better = ("falls", "time_to_stand", "height_error", "velocity_error", "yaw_rate_error")

    def __init__(
        self,
        model_path: str | Path = MODEL_PATH,
        sim_model_path: str | Path | None = None,
        policy_path: str | Path | None = POLICY_PATH,
    ) -> None:
        super().__init__(model_path, sim_model_path)
        nq, speeds = self.model.nq, [self.get_joint_velocity_start_index(j) for j in JOINTS]
        self.proprioception = np.concatenate([self._joint_qpos, speeds, np.arange(nq + 3, nq + 6)])
        """(27,) state columns of the joint angles, joint speeds and gyro (in the base frame)."""
        self._policy = None if policy_path is None else GaitPolicy.load(policy_path)

    def default_proposal_policy(self) -> Policy | None:
        """The trot's gait policy (numpy), whose candidates the optimizer scores among its own."""
        return self._policy

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 35) OBSERVATION of (B, nq + nv) states, the config's `velocity_command` and the (B,
        nsensordata) sensors' "clock"; `previous_actions` is not used."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        if sensors is None:
            raise PolicyError("go2_walk's policy observation needs the sensors, for the gait clock")
        times = np.atleast_2d(np.asarray(sensors, dtype=float))[:, self._clock]
        commands = np.broadcast_to(self.config.velocity_command, (len(states), 3))
        return locomotion_features(states, self.proprioception, POSTURE, commands, times)

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: Go2WalkConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,): `base_cost`, the feet's heights against
        the gait, and the heading-frame velocity and yaw rate against the command."""
        targets = swing_heights(sensors[..., self._clock], gait_of(config.gait), config.step_height)
        foot_error = sensors[..., self._feet + 2] - FOOT_RADIUS - targets
        velocity = self.body_velocity(sensors)
        command = config.velocity_command
        cost = (
            self.base_cost(states, sensors, controls, config)
            + config.w_gait * np.square(foot_error).sum(-1)
            + config.w_velocity * np.square(velocity[..., :2] - command[:2]).sum(-1)
            + config.w_yaw_rate * np.square(velocity[..., 2] - command[2])
        )
        return -cost.mean(-1)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """`Go2Base.metrics` and velocity_error: mean horizontal velocity error (m/s) in the heading
        frame; yaw_rate_error: mean absolute yaw-rate error (rad/s); each compares the command with
        the velocities averaged over the AVERAGE_WINDOW (0.5 s) before the step, from the first
        second on (the start from rest)."""
        velocity = self.body_velocity(log.sensors)
        window = max(1, round(AVERAGE_WINDOW / float(self.sim_model.opt.timestep)))
        averaged = np.stack([trailing_mean(velocity[:, i], window) for i in range(3)], axis=1)
        after = log.times - log.times[0] >= 1.0
        if not after.any():
            after[:] = True
        command = self.config.velocity_command
        error = np.hypot(*(averaged[after, :2] - command[:2]).T)
        return {
            **super().metrics(log),
            "velocity_error": float(error.mean()),
            "yaw_rate_error": float(np.abs(averaged[after, 2] - command[2]).mean()),
        }
