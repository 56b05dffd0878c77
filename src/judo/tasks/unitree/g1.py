"""G1 stand: Unitree's G1 humanoid (29 DoF) holds its standing pose under random pushes.

The model is MuJoCo Menagerie's G1 with Unitree's joint PD as position servos
(models/unitree_g1/g1.xml). The planner plans all 29 joint targets; the reward holds the pelvis at
its standing height and upright, the capture point over the feet, the joints near Unitree's standing
pose, and little torque. The plant is pushed at random (RandomPushes): the planner only sees what
the push did to the state. By default some of the optimizer's candidates each update come from a
shipped balance policy (`default_proposal_policy`; `python -m judo gait-search --task g1_stand`):
the standing pose plus linear feedback on the pelvis's gyro, tilt and velocity.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.norms import smooth_l1_norm
from judo.core.policy import Policy
from judo.core.task import EpisodeLog, Task, TaskConfig
from judo.tasks.gait_policy import COMMAND_FEATURES, HARMONICS, GaitLayout, GaitPolicy
from judo.tasks.quadruped import gravity_in_body
from judo.tasks.unitree.pushes import RandomPushes

MODEL_PATH = Path(__file__).parents[1] / "models" / "unitree_g1" / "g1.xml"
MOTOR_JOINTS = (
    *(f"{side}_{j}_joint" for side in ("left", "right")
      for j in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")),
    "waist_yaw_joint",
    "waist_roll_joint",
    "waist_pitch_joint",
    *(f"{side}_{j}_joint" for side in ("left", "right")
      for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")),  # noqa: E501
)  # fmt: skip
"""The 29 joints in Unitree's motor order (motor i drives MOTOR_JOINTS[i]); the actuators are named
as them."""
STANDING_HEIGHT = 0.6
"""Pelvis height (m) above which, upright, `metrics` counts the robot as standing (the standing
pose: 0.78 m)."""
FALL_HEIGHT = 0.45
"""Pelvis height (m) below which the plant counts a fall and stands the robot up again where it
lies."""
UPRIGHT_COS = np.cos(np.radians(30.0))
"""The pelvis counts as upright while its z axis is within 30 degrees of vertical."""
GRAVITY = 9.81
"""Gravity (m/s^2) used for the capture point."""
OBSERVATION = (
    "pelvis angular velocity in the pelvis frame (3, rad/s, the free joint's: what the IMU's gyro "
    "reads), gravity's direction in the pelvis frame (3), the pelvis's linear velocity in the "
    "pelvis frame (3, m/s), a zero command (3) and a constant clock [1, 0] (2)"
)
"""What `G1Stand.policy_observation` holds: 14 values; the command and clock columns are there
so that the balance policy is a judo.tasks.gait_policy GaitLayout (the constant clock and zero
command leave its harmonics as constant offsets)."""
OBSERVATION_SIZE = 14
FEEDBACK_COLUMNS = np.arange(9)
"""The observation's columns the balance policy feeds back: gyro, gravity, velocity."""
BALANCE_JOINTS = 15
"""The balance policy offsets and feeds back into the first 15 motors (legs and waist); the arms
hold the standing pose."""
KICK_SPEEDS = (0.2, 0.4)
"""[low, high] (m/s) of the start speeds `draw_kick` draws: what a 40 N x 0.2 s push gives the
35 kg robot (0.23 m/s), with margin."""
POLICY_PATH = Path(__file__).parents[1] / "models" / "policies" / "g1_balance.json"
"""g1_stand's default proposal policy (`python -m judo gait-search --task g1_stand`)."""


def balance_features(states: np.ndarray, nq: int, out: np.ndarray | None = None) -> np.ndarray:
    """(B, 14) OBSERVATION of (B, nq + nv) states with the free joint first (qpos[3:7] its [w, x,
    y, z] quaternion, qvel[:3] its world-frame velocity, qvel[3:6] its angular velocity in its own
    frame); written into the (B, 14) `out` where given."""
    if out is None:
        out = np.empty((len(states), OBSERVATION_SIZE))
    quat = states[:, 3:7]
    out[:, 0:3] = states[:, nq + 3 : nq + 6]
    gravity_in_body(quat, out=out[:, 3:6])
    # R^T v for q = (w, u): v - 2 w (u x v) + 2 u x (u x v)
    w, u, velocity = quat[:, :1], quat[:, 1:], states[:, nq : nq + 3]
    twist = np.cross(u, velocity)
    out[:, 6:9] = velocity - 2.0 * w * twist + 2.0 * np.cross(u, twist)
    out[:, 9:] = (0.0, 0.0, 0.0, 1.0, 0.0)
    return out


def balance_layout(home: np.ndarray) -> GaitLayout:
    """The balance policy's GaitLayout on OBSERVATION around the (29,) standing targets `home`:
    feedback on FEEDBACK_COLUMNS; the zero command and constant clock make its harmonic weights
    constant offsets (the search tunes one per joint: `balance_parameters`)."""
    return GaitLayout(
        home=np.array(home, dtype=float),
        command_columns=np.arange(9, 12),
        clock_columns=np.arange(12, 14),
        feedback_columns=FEEDBACK_COLUMNS,
        phase_signs=np.ones(len(home)),
        observation_size=OBSERVATION_SIZE,
    )


@slider("target_height", 0.6, 0.85, 0.005)
@slider("w_height", 0.0, 500.0, 1.0)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_balance", 0.0, 50.0, 0.1)
@slider("w_posture", 0.0, 5.0, 0.01)
@slider("w_velocity", 0.0, 20.0, 0.1)
@slider("w_effort", 0.0, 1.0, 0.001)
@slider("w_feet", 0.0, 5000.0, 10.0)
@slider("push_force", 0.0, 200.0, 1.0)
@slider("push_interval", 0.5, 10.0, 0.1)
@slider("push_duration", 0.02, 1.0, 0.01)
@dataclass
class G1StandConfig(TaskConfig):
    """G1 standing weights, target and the plant's pushes."""

    target_height: float = 0.78
    """Pelvis height (m) to hold; Unitree's standing pose (knees 0.3 rad bent) puts it at 0.78 m."""
    w_height: float = 100.0
    """Weight on the pelvis height error (squared, m^2)."""
    w_upright: float = 5.0
    """Weight on the pelvis and the torso tilting (1 - cos of each one's angle from vertical,
    summed)."""
    w_balance: float = 10.0
    """Weight on the horizontal distance (m) from the capture point (the centre of mass moved on by
    its velocity times sqrt(height / g)) to the midpoint of the feet (smooth L1, quadratic within
    0.05 m)."""
    w_posture: float = 0.5
    """Weight on the joint angles differing from the standing pose (squared, summed, rad^2)."""
    w_velocity: float = 1.0
    """Weight on the centre of mass's horizontal speed (squared, m^2/s^2), so it comes to rest."""
    w_effort: float = 0.01
    """Weight on the servos' torques as a share of their limits (squared, summed)."""
    w_feet: float = 0.0
    """Weight on the feet's soles rising off the floor (squared height, summed over both feet,
    m^2)."""
    push_force: float = 40.0
    """Force (N) of each random horizontal push on the plant's pelvis; 0 turns pushes off."""
    push_interval: float = 4.0
    """Seconds between pushes (the first comes this long after a reset); read at each reset."""
    push_duration: float = 0.2
    """Seconds each push lasts (40 N for 0.2 s gives the 35 kg robot 0.23 m/s)."""


def balance_parameters(layout: GaitLayout) -> np.ndarray:
    """(P,) bool: the parameters of `layout` the search tunes, those of the first BALANCE_JOINTS
    motors: each one's offset (its constant harmonic weight, W[j, 0, 0]) and its feedback gains
    (the (J, F) gains follow the J x 5 x 4 harmonic weights: GaitLayout.split)."""
    joints, cut = layout.num_joints, layout.num_joints * HARMONICS * COMMAND_FEATURES
    free = np.zeros(layout.num_parameters, dtype=bool)
    free[:cut].reshape(joints, HARMONICS, COMMAND_FEATURES)[:BALANCE_JOINTS, 0, 0] = True
    free[cut:].reshape(joints, -1)[:BALANCE_JOINTS] = True
    return free


def ankle_and_hip_strategy(layout: GaitLayout) -> np.ndarray:
    """(P,) the balance search's first mean: no offsets, and feedback only into the ankles' pitch
    (4 per unit of forward gravity, 0.3 per rad/s of pitch rate, 1 per m/s of forward velocity)
    and the hips' roll (2 per unit of sideways gravity, 1 per m/s of sideways velocity). Set by
    hand from a coarse grid over those gains on 8 kicks (docs/tasks.md): from zero, all candidates
    fall and the search finds nothing to climb."""
    joints, cut = layout.num_joints, layout.num_joints * HARMONICS * COMMAND_FEATURES
    parameters = np.zeros(layout.num_parameters)
    gains = parameters[cut:].reshape(joints, -1)  # columns: gyro, gravity, velocity (x, y, z)
    ankles_pitch, hips_roll = [4, 10], [1, 7]
    gains[ankles_pitch, 3], gains[ankles_pitch, 1], gains[ankles_pitch, 6] = 4.0, 0.3, 1.0
    gains[hips_roll, 4], gains[hips_roll, 7] = 2.0, 1.0
    return parameters


def draw_kick(rng: np.random.Generator) -> np.ndarray:
    """(3,) [vx, vy, 0] (m/s): a horizontal start velocity of a speed in KICK_SPEEDS in a direction
    drawn from `rng`, the search's stand-in for a push."""
    speed, angle = rng.uniform(*KICK_SPEEDS), rng.uniform(-np.pi, np.pi)
    return np.array([speed * np.cos(angle), speed * np.sin(angle), 0.0])


class G1Stand(Task[G1StandConfig]):
    """State [pelvis position (3), quaternion (4), 29 joint angles, pelvis velocity (6), 29 joint
    velocities]; the
    29 controls are joint position targets (rad) in Unitree's motor order (MOTOR_JOINTS), which the
    servos track with the robot's own kp and kd (the model's actuators). `policy_path`: the default
    proposal policy's JSON file, or None: none."""

    focus_body = "pelvis"
    lower_is_better: ClassVar[tuple[str, ...]] = ("falls", "falls_per_minute", "rms_height_error")
    measured_sensors = (
        *(f"{joint}_pos" for joint in MOTOR_JOINTS),
        *(f"{joint}_vel" for joint in MOTOR_JOINTS),
        "imu_quat",
        "imu_gyro",
        "imu_acc",
    )
    """What the G1's rt/lowstate carries: 29 joint encoders (q, then dq, in motor order) and the
    pelvis IMU."""
    default_estimator = "legged"
    """The filter that makes the floating base from those readings (no base pose or foot force is
    measured)."""

    def __init__(
        self,
        model_path: str | Path = MODEL_PATH,
        sim_model_path: str | Path | None = None,
        policy_path: str | Path | None = POLICY_PATH,
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._policy = None if policy_path is None else GaitPolicy.load(policy_path)
        self.home_key = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_KEY, "home")
        self.home_ctrl = self.model.key_ctrl[self.home_key].copy()
        """(29,) Unitree's standing pose's joint targets, in motor order."""
        self._joint_qpos = np.array([self.get_joint_position_start_index(j) for j in MOTOR_JOINTS])
        self._pelvis = self.get_sensor_start_index("trace_pelvis")
        self._feet = np.array(
            [self.get_sensor_start_index(f"trace_{side}_foot") for side in ("left", "right")]
        )
        self._pelvis_up = self.get_sensor_start_index("pelvis_up")
        self._torso_up = self.get_sensor_start_index("torso_up")
        self._com = self.get_sensor_start_index("center_of_mass")
        self._com_velocity = self.get_sensor_start_index("center_of_mass_velocity")
        self._torque_per_rad = self.model.actuator_gainprm[:, 0] / np.abs(
            self.model.actuator_forcerange[:, 1]
        )
        self.pushes = RandomPushes(self.sim_model, "pelvis")
        self.falls = 0
        self.reset()

    def default_proposal_policy(self) -> Policy | None:
        """The balance policy (numpy), whose candidates the optimizer scores among its own."""
        return self._policy

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 14) OBSERVATION of (B, nq + nv) states; the other arguments are not used."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        return balance_features(states, self.model.nq)

    def pelvis_height(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the pelvis height (m) from (..., nsensordata) sensor rows."""
        return sensors[..., self._pelvis + 2]

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: G1StandConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,), from (num_rollouts, T, nq + nv) states,
        (num_rollouts, T, nsensordata) sensors and (num_rollouts, T, 29) controls."""
        height_error = self.pelvis_height(sensors) - config.target_height
        tilt = 2.0 - sensors[..., self._pelvis_up + 2] - sensors[..., self._torso_up + 2]
        feet_middle = 0.5 * (
            sensors[..., self._feet[0] : self._feet[0] + 2]
            + sensors[..., self._feet[1] : self._feet[1] + 2]
        )
        com = sensors[..., self._com : self._com + 3]
        com_velocity = sensors[..., self._com_velocity : self._com_velocity + 2]
        # Capture point: where the centre of mass would come to rest over, as for an inverted
        # pendulum.
        capture_point = com[..., :2] + com_velocity * np.sqrt(
            np.maximum(com[..., 2:3], 0.0) / GRAVITY
        )
        joints = states[..., self._joint_qpos]
        torque_share = (controls - joints) * self._torque_per_rad
        cost = (
            config.w_height * np.square(height_error)
            + config.w_upright * tilt
            + config.w_balance * smooth_l1_norm(capture_point - feet_middle, 0.05)
            + config.w_posture * np.square(joints - self.home_ctrl).sum(-1)
            + config.w_velocity * np.square(com_velocity).sum(-1)
            + config.w_effort * np.square(torque_share).sum(-1)
            + config.w_feet * np.square(sensors[..., self._feet + 2]).sum(-1)
        )
        return -cost.mean(-1)

    def stand_at(self, x: float, y: float, yaw: float) -> None:
        """Put the plant in the "home" standing pose, at rest, at (x, y) facing `yaw` (rad)."""
        key_qpos = self.sim_model.key_qpos[self.home_key]
        self.data.qpos[:] = key_qpos
        self.data.qpos[:2] = (x, y)
        mujoco.mju_mulQuat(
            self.data.qpos[3:7],
            np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]),
            key_qpos[3:7],
        )
        self.data.qvel[:] = 0.0
        self.data.ctrl[:] = self.home_ctrl
        self.data.xfrc_applied[:] = 0.0
        mujoco.mj_forward(self.sim_model, self.data)

    def reset(self) -> None:
        """Standing in Unitree's standing pose at the origin, facing +x, at rest; pushes and falls
        at zero."""
        mujoco.mj_resetDataKeyframe(self.sim_model, self.data, self.home_key)
        self.stand_at(0.0, 0.0, 0.0)
        self.data.time = 0.0
        self.pushes.reset(self.config.push_interval)
        self.falls = 0

    def pre_sim_step(self) -> None:
        """Push the plant's pelvis when a push is due (config.push_force, push_interval,
        push_duration)."""
        config = self.config
        self.pushes.apply(
            self.data, self.rng, config.push_force, config.push_interval, config.push_duration
        )

    def post_sim_step(self) -> None:
        """Count a fall (pelvis below FALL_HEIGHT) and stand the robot up again where it lies."""
        if self.data.qpos[2] < FALL_HEIGHT:
            self.falls += 1
            w, _, _, z = self.data.qpos[3:7]
            self.stand_at(self.data.qpos[0], self.data.qpos[1], 2.0 * np.arctan2(z, w))

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(29,) the standing pose's joint targets: with no noise, the plan stands."""
        return self.home_ctrl.copy()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(29,) the standing pose's joint targets: the servos hold the standing pose (a robot that
        is falling is better caught in it than frozen in its current joint angles)."""
        return self.home_ctrl.copy()

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """The feet's six contact pairs with the floor: sliding friction x U[0.7, 1.3] (one draw
        each)."""
        feet = [
            i for i in range(model.npair) if "foot" in model.geom(int(model.pair_geom1[i])).name
        ]
        model.pair_friction[feet, :2] *= rng.uniform(0.7, 1.3, (len(feet), 1))

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """standing_fraction: share of the steps with the pelvis above 0.6 m and within 30 degrees
        of upright; falls and falls_per_minute (pelvis below 0.45 m, counted on this plant task);
        pushes: pushes given; rms_height_error: RMS (m) of the pelvis height from
        config.target_height."""
        height = self.pelvis_height(log.sensors)
        upright = log.sensors[:, self._pelvis_up + 2] > UPRIGHT_COS
        minutes = len(log.times) * float(self.sim_model.opt.timestep) / 60.0
        return {
            "standing_fraction": float(np.mean((height > STANDING_HEIGHT) & upright)),
            "falls": float(self.falls),
            "falls_per_minute": self.falls / minutes if minutes > 0 else 0.0,
            "pushes": float(self.pushes.count),
            "rms_height_error": float(
                np.sqrt(np.mean(np.square(height - self.config.target_height)))
            ),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: no fall."""
        return bool(metrics["falls"] == 0)
