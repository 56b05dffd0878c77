"""Quadruped: a 12-joint, Go1-class quadruped walks to a goal on the floor, planned directly in
joint targets.

The reward follows MJPC's quadruped: keep the trunk at its height and upright, walk towards the goal
facing it, lift the feet on a gait schedule (trot, walk, or stand), and spend little effort. The
gait's clock is the model's "clock" sensor, so every rollout knows where in the stride each of its
steps falls.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.norms import smooth_l1_norm
from judo.core.rollouts.randomize import contact_geom_ids, scale_geom_friction
from judo.core.task import ConfigT, EpisodeLog, Task, TaskConfig
from judo.tasks.gait import CLOCK_RAD_PER_S, LEGS, GaitName, gait_of, swing_heights

MODEL_PATH = Path(__file__).parent / "models" / "quadruped.xml"
JOINTS = tuple(f"{leg}_{joint}" for leg in LEGS for joint in ("abduction", "hip", "knee"))
"""The 12 joints in actuator order."""
FOOT_RADIUS = 0.02
"""Radius (m) of the foot spheres: a foot on the floor has its site this high."""
STANDING_HEIGHT = 0.2976
"""Trunk height (m) of the "home" keyframe; the robot counts as fallen below half of it."""


DOWN_IN_BODY_FORMS = -np.array(
    [
        [[0, 0, -1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, 1, 0, 0]],  # 2 (xz - wy)
        [[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 1, 0]],  # 2 (yz + wx)
        # w^2 - x^2 - y^2 + z^2 = 1 - 2 (x^2 + y^2)
        [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]],
    ],
    dtype=float,
)
"""(3, 4, 4) symmetric Q_k with q^T Q_k q the k-th component of R(q)^T [0, 0, -1] for a unit q = [w,
x, y, z]."""


def gravity_in_body(quat: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(..., 3) the world's down direction in the frame of (..., 4) unit quaternions [w, x, y, z]:
    R^T [0, 0, -1], as three quadratic forms in one einsum (a fifth of the cost of the twelve small
    array operations it replaces, on the 4-row batches a low-level tick observes); written into the
    (..., 3) `out` where given."""
    return np.einsum("...i,kij,...j->...k", quat, DOWN_IN_BODY_FORMS, quat, out=out)


def locomotion_features(
    states: np.ndarray,
    proprioception: np.ndarray,
    pose: np.ndarray,
    commands: np.ndarray,
    times: np.ndarray,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """(B, 35) a legged robot's locomotion observation in quadruped_velocity.OBSERVATION's layout:
    from (B, nq + nv) states with the free joint first, its (27,) `proprioception` columns (12 joint
    angles, less the (12,) `pose`, 12 joint speeds, the free joint's angular velocity, in the base
    frame: the gyro), gravity's direction in the base frame, the (B, 3) commands and the trot's
    clock [cos, sin] at (B,) sim `times`; written into the (B, 35) `out` where given."""
    if out is None:
        out = np.empty((len(states), 35))
    np.take(states, proprioception, axis=1, out=out[:, :27], mode="clip")
    out[:, :12] -= pose
    gravity_in_body(states[:, 3:7], out=out[:, 27:30])
    out[:, 30:33] = commands
    phase = CLOCK_RAD_PER_S * np.asarray(times, dtype=float)
    out[:, 33], out[:, 34] = np.cos(phase), np.sin(phase)
    return out


LOCOMOTION_OBSERVATION_SIZE = 35
"""Width of `locomotion_observation`: 12 joint angles, 12 joint speeds, gyro, gravity, command,
clock."""


@slider("target_height", 0.15, 0.35, 0.005)
@slider("step_height", 0.0, 0.15, 0.005)
@slider("w_height", 0.0, 1000.0, 1.0)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_gait", 0.0, 1000.0, 1.0)
@slider("w_velocity", 0.0, 20.0, 0.1)
@slider("w_posture", 0.0, 5.0, 0.01)
@slider("w_effort", 0.0, 1.0, 0.001)
@dataclass
class QuadrupedBaseConfig(TaskConfig):
    """What both quadruped tasks weigh: height, uprightness, the gait, velocity, posture and
    effort."""

    gait: GaitName = "trot"
    """The foot schedule: "trot" (diagonal pairs, 2.5 Hz), "walk" (one foot at a time, 1.25 Hz) or
    "stand" (no foot is asked to lift; the goal task still shuffles towards its goal, as the
    velocity task does towards a command)."""
    target_height: float = 0.29
    """Trunk height (m) to hold; the standing pose puts it at 0.30 m."""
    step_height: float = 0.07
    """How high (m) a swinging foot is lifted at mid-swing."""
    w_height: float = 400.0
    """Weight on the trunk's height error (squared, m^2)."""
    w_upright: float = 10.0
    """Weight on the trunk tilting (1 - cos of its angle from vertical)."""
    w_gait: float = 200.0
    """Weight on each foot's height differing from the gait's schedule (squared, summed over feet,
    m^2)."""
    w_velocity: float = 2.0
    """Weight on the trunk's horizontal velocity differing from the one asked for (squared,
    m^2/s^2)."""
    w_posture: float = 0.1
    """Weight on the joint angles differing from the standing pose (squared, summed, rad^2)."""
    w_effort: float = 0.01
    """Weight on the joint torques the servos spend, as a share of their limit (squared, summed)."""


class QuadrupedBase(Task[ConfigT]):
    """What both quadruped tasks share: the model, its sensors, the standing pose, the gait and
    falls.

    State [trunk position (3), quaternion (4), 12 joint angles, trunk velocity (6), 12 joint
    velocities]; the 12 controls are joint position targets (rad), legs FR, FL, RR, RL, each
    abduction, hip, knee.
    """

    focus_body = "torso"
    lower_is_better: ClassVar[tuple[str, ...]] = ("falls",)
    measured_sensors = (
        *(f"{joint}_pos" for joint in JOINTS),
        "imu_quat",
        "imu_gyro",
        "imu_accel",
        *(f"{leg}_touch" for leg in LEGS),
    )
    """12 joint encoders, a trunk IMU (orientation, gyro, accelerometer) and a contact switch in
    each foot."""

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._home_key = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_KEY, "home")
        self.home_ctrl = self.model.key_ctrl[self._home_key].copy()
        """(12,) the standing pose's joint targets."""
        self._joint_qpos = np.array([self.get_joint_position_start_index(j) for j in JOINTS])
        self._joint_qvel = np.array([self.get_joint_velocity_start_index(j) for j in JOINTS])
        nq = self.model.nq
        self._proprioception = np.concatenate(
            [self._joint_qpos, self._joint_qvel, np.arange(nq + 3, nq + 6)]
        )
        """(27,) the state columns the locomotion observation starts with: joint angles, joint
        speeds, gyro."""
        self._torso = self.get_sensor_start_index("trace_torso")
        self._feet = np.array(
            [self.get_sensor_start_index(f"trace_{leg}_foot") + 2 for leg in LEGS]
        )
        self._up = self.get_sensor_start_index("torso_up")
        self._forward = self.get_sensor_start_index("torso_forward")
        self._velocity = self.get_sensor_start_index("torso_world_velocity")
        self._clock = self.get_sensor_start_index("clock")
        self._torque_per_rad = self.model.actuator_gainprm[:, 0] / np.abs(
            self.model.actuator_forcerange[:, 1]
        )
        self.falls = 0

    def base_cost(
        self, states: np.ndarray, sensors: np.ndarray, controls: np.ndarray, config: Any
    ) -> np.ndarray:
        """(num_rollouts, T) the per-step cost of height, tilt, gait, posture and effort from
        (num_rollouts, T, nq + nv) states, (num_rollouts, T, nsensordata) sensors and (num_rollouts,
        T, 12) controls."""
        height_error = sensors[..., self._torso + 2] - config.target_height
        tilt = 1.0 - sensors[..., self._up + 2]
        targets = swing_heights(sensors[..., self._clock], gait_of(config.gait), config.step_height)
        foot_error = sensors[..., self._feet] - FOOT_RADIUS - targets
        joints = states[..., self._joint_qpos]
        torque_share = (controls - joints) * self._torque_per_rad
        return (
            config.w_height * np.square(height_error)
            + config.w_upright * tilt
            + config.w_gait * np.square(foot_error).sum(-1)
            + config.w_posture * np.square(joints - self.home_ctrl).sum(-1)
            + config.w_effort * np.square(torque_share).sum(-1)
        )

    def velocity_cost(self, sensors: np.ndarray, wanted: np.ndarray, config: Any) -> np.ndarray:
        """(num_rollouts, T) w_velocity times the squared difference between the trunk's horizontal
        world velocity and `wanted`, (num_rollouts, T, 2) m/s."""
        velocity = sensors[..., self._velocity : self._velocity + 2]
        return config.w_velocity * np.square(velocity - wanted).sum(-1)

    def heading(self, sensors: np.ndarray) -> np.ndarray:
        """(...,) the trunk's yaw (rad) from (..., nsensordata) sensor rows."""
        return np.arctan2(sensors[..., self._forward + 1], sensors[..., self._forward])

    def stand_at(self, x: float, y: float, yaw: float) -> None:
        """Put the plant in the standing pose of "home", at rest, at (x, y) facing `yaw` (rad)."""
        key_qpos = self.sim_model.key_qpos[self._home_key]
        self.data.qpos[:] = key_qpos
        self.data.qpos[:2] = (x, y)
        turn = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        mujoco.mju_mulQuat(self.data.qpos[3:7], turn, key_qpos[3:7].copy())
        self.data.qvel[:] = 0.0
        self.data.ctrl[:] = self.home_ctrl
        mujoco.mj_forward(self.sim_model, self.data)

    def locomotion_observation(
        self,
        commands: np.ndarray,
        states: np.ndarray,
        previous: np.ndarray | None,
        times: np.ndarray,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 35) the locomotion observation (quadruped_velocity.OBSERVATION) of (B, 3) commands
        [vx, vy, yaw rate], (B, nq + nv) states and (B,) sim times (s), one command per row: what
        quadruped_velocity's `policy_observation` gives, and quadruped_navigate's low-level hook
        (hence a hook's argument order). The (B, 12) `previous` joint targets are not part of it: a
        policy cloned from the MPC with them learned to copy them (the copycat problem of behaviour
        cloning; docs/tasks.md). Written into the (B, 35) `out` where given (a low-level tick's
        buffer: one gather and a few small writes, no concatenated temporaries)."""
        return locomotion_features(
            states, self._proprioception, self.home_ctrl, commands, times, out
        )

    def post_sim_step(self) -> None:
        """Count a fall (trunk below half its standing height) and stand the robot up where it
        lies."""
        if self.data.qpos[2] < 0.5 * STANDING_HEIGHT:
            self.falls += 1
            w, _, _, z = self.data.qpos[3:7]
            self.stand_at(self.data.qpos[0], self.data.qpos[1], 2.0 * np.arctan2(z, w))

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(12,) the standing pose's joint targets: with no noise, the plan stands."""
        return self.home_ctrl.copy()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(12,) the standing pose's joint targets: the servos hold the robot up rather than freeze
        it."""
        return self.home_ctrl.copy()

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.7, 1.3] (its own draw): the feet's grip on the
        floor."""
        scale_geom_friction(model, contact_geom_ids(model), 0.7, 1.3, rng)


@slider("speed", 0.0, 1.5, 0.05)
@slider("goal_radius", 0.05, 1.0, 0.05)
@slider("w_goal", 0.0, 20.0, 0.1)
@slider("w_heading", 0.0, 20.0, 0.1)
@dataclass
class QuadrupedConfig(QuadrupedBaseConfig):
    """Quadruped goal-walking weights and goal rule. The goal is the mocap body "goal": drag it in
    the GUI."""

    speed: float = 0.6
    """Walking speed (m/s) to head for the goal with, slowing down within 0.5 m of it."""
    goal_radius: float = 0.25
    """Horizontal distance (m) from the trunk within which the goal counts as reached."""
    new_goal_on_reach: bool = True
    """Move the goal to a random spot 1 to 2 m away whenever it is reached (turn off to place goals
    by hand)."""
    w_goal: float = 0.2
    """Weight on the trunk's horizontal distance (m) from the goal (smooth L1: quadratic within 0.1
    m)."""
    w_heading: float = 1.0
    """Weight on the trunk facing away from the goal (1 - cos of the yaw error), while farther than
    goal_radius."""


class WalkToGoalBase(QuadrupedBase[ConfigT]):
    """What both walk-to-goal tasks (quadruped, quadruped_navigate) share: the goal's cost terms,
    read through the
    "goal_position" sensor, and the plant's goal rule: once the trunk is within `goal_radius` of the
    mocap goal,
    `pre_sim_step` counts it and draws a new one 1 to 2 m away (while `new_goal_on_reach`). Their
    configs have speed, goal_radius, new_goal_on_reach, w_velocity, w_heading and w_goal.
    """

    lower_is_better: ClassVar[tuple[str, ...]] = ("falls", "final_distance")

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._goal = self.get_sensor_start_index("goal_position")
        self.goals_reached = 0
        self.reset()

    def goal_cost(self, sensors: np.ndarray, config: Any) -> np.ndarray:
        """(num_rollouts, T) walking towards the goal at config.speed (slowing within 0.5 m), facing
        it while farther than config.goal_radius (w_heading), and its distance (w_goal, smooth L1),
        from (num_rollouts, T, nsensordata) sensors: the goal task's terms, which quadruped_navigate
        plans over its policy too."""
        offset = (
            sensors[..., self._goal : self._goal + 2] - sensors[..., self._torso : self._torso + 2]
        )
        distance = np.linalg.norm(offset, axis=-1, keepdims=True)
        direction = offset / np.maximum(distance, 1e-6)
        wanted = direction * config.speed * np.minimum(distance / 0.5, 1.0)
        yaw_error = self.heading(sensors) - np.arctan2(offset[..., 1], offset[..., 0])
        far = distance[..., 0] > config.goal_radius
        return (
            self.velocity_cost(sensors, wanted, config)
            + config.w_heading * far * (1.0 - np.cos(yaw_error))
            + config.w_goal * smooth_l1_norm(offset, 0.1)
        )

    def reset(self) -> None:
        """Standing at the origin facing +x, at rest; a goal 1 m ahead; counters at zero."""
        mujoco.mj_resetDataKeyframe(self.sim_model, self.data, self._home_key)
        self.data.mocap_pos[0, :2] = (1.0, 0.0)
        mujoco.mj_forward(self.sim_model, self.data)
        self.goals_reached = 0
        self.falls = 0

    def goal_distance(self) -> float:
        """Horizontal distance (m) from the plant's trunk to the goal."""
        return float(np.linalg.norm(self.data.qpos[:2] - self.data.mocap_pos[0, :2]))

    def pre_sim_step(self) -> None:
        """Count a reached goal and draw the next one 1 to 2 m from the trunk, in any direction."""
        config: Any = self.config
        if config.new_goal_on_reach and self.goal_distance() < config.goal_radius:
            self.goals_reached += 1
            angle, distance = self.rng.uniform(-np.pi, np.pi), self.rng.uniform(1.0, 2.0)
            self.data.mocap_pos[0, :2] = self.data.qpos[:2] + distance * np.array(
                [np.cos(angle), np.sin(angle)]
            )

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """goals_reached and goals_per_minute (counted on this plant task), falls (trunk below half
        its standing height), and final_distance (m) from the trunk to the last goal."""
        minutes = len(log.times) * float(self.sim_model.opt.timestep) / 60.0
        return {
            "goals_reached": float(self.goals_reached),
            "goals_per_minute": self.goals_reached / minutes if minutes > 0 else 0.0,
            "falls": float(self.falls),
            "final_distance": self.goal_distance(),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: at least one goal reached and no fall."""
        return bool(metrics["goals_reached"] >= 1 and metrics["falls"] == 0)


class Quadruped(WalkToGoalBase[QuadrupedConfig]):
    """Walk to the mocap goal; once the trunk is within `goal_radius` of it, the plant draws a new
    one 1 to 2 m away.

    The reward reads the goal through the "goal_position" sensor. On the plant, `pre_sim_step`
    counts reached goals and `post_sim_step` counts falls (and stands the robot up where it fell).
    """

    config_cls = QuadrupedConfig

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: QuadrupedConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,): `base_cost`, walking towards the goal at
        `speed`, and facing it."""
        cost = self.base_cost(states, sensors, controls, config) + self.goal_cost(sensors, config)
        return -cost.mean(-1)
