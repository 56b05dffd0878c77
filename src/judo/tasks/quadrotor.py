"""Quadrotor: a rigid body lifted by four rotor thrusts flies to goal poses, on its own equations of
motion (numpy, not MuJoCo).

The airframe is MuJoCo Menagerie's Skydio X2 (skydio_x2/x2.xml): 1.325 kg (a 0.325 kg body and four
0.25 kg rotors at x = +-0.14 m, y = +-0.18 m), each rotor's thrust within 0 to 13 N with a yaw
moment of 0.0201 N m per N (rotors 1 and 3 turning one way, 2 and 4 the other); hover is 3.25 N a
rotor. The inertia is that of those masses (rotor and body ellipsoids at their offsets):
diag(0.0359, 0.0247, 0.0605) kg m^2. The motion is the Newton-Euler rigid body of Mahony, Kumar and
Corke, "Multirotor Aerial Vehicles", IEEE RAM 2012, eqs. (3)-(5), stepped by semi-implicit Euler
with the quaternion renormalized.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.configuration.fields import slider
from judo.core.model import mocap_pose
from judo.core.norms import smooth_l1_norm
from judo.core.rollouts.dynamics import DynamicsTask
from judo.core.task import EpisodeLog, TaskConfig

MASS = 1.325
"""Total mass (kg) (Skydio X2, Menagerie)."""
INERTIA = np.array([0.0359, 0.0247, 0.0605])
"""Principal moments of inertia (kg m^2) of the X2's rotor and body masses."""
ROTORS = np.array([[-0.14, -0.18], [-0.14, 0.18], [0.14, 0.18], [0.14, -0.18]])
"""(4, 2) rotor positions (m) in the body's x-y plane (Menagerie's thrust sites)."""
YAW_MOMENT = np.array([-0.0201, 0.0201, -0.0201, 0.0201])
"""(4,) yaw moment (N m) per newton of each rotor's thrust (Menagerie's motor gears)."""
MAX_THRUST = 13.0
"""Most thrust (N) of one rotor (Menagerie's ctrlrange)."""
GRAVITY = 9.81
HOVER = MASS * GRAVITY / 4 / MAX_THRUST
"""Each rotor's control (a fraction of MAX_THRUST) that holds the quadrotor in a hover: 0.25."""
DT = 0.01
"""Step (s): 100 Hz."""
YAW_TOLERANCE = 0.5
"""Heading error (rad) within which a goal pose counts as reached (with the distance within
`goal_radius`)."""
GOAL_LOW, GOAL_HIGH = np.array([-1.5, -1.5, 0.6]), np.array([1.5, 1.5, 2.0])
"""Corners (m) of the box new goals are drawn from."""


def z_axis(quat: np.ndarray) -> np.ndarray:
    """(..., 3) the body's z axis in the world, of (..., 4) unit quaternions [w, x, y, z]."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)


def yaw_of(quat: np.ndarray) -> np.ndarray:
    """(...,) heading (rad) of (..., 4) quaternions [w, x, y, z]."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


@slider("w_position", 0.0, 20.0, 0.1)
@slider("w_upright", 0.0, 20.0, 0.1)
@slider("w_yaw", 0.0, 5.0, 0.05)
@slider("w_velocity", 0.0, 2.0, 0.01)
@slider("w_angular_velocity", 0.0, 1.0, 0.005)
@slider("w_control", 0.0, 5.0, 0.01)
@slider("goal_radius", 0.05, 1.0, 0.05)
@dataclass
class QuadrotorConfig(TaskConfig):
    """Quadrotor reward weights and goal rule. The goal pose is the mocap body "goal": drag and turn
    it in the GUI."""

    w_position: float = 5.0
    """Weight on the distance (m) to the goal."""
    w_upright: float = 2.0
    """Weight on tilt: 1 - the body z axis's vertical component."""
    w_yaw: float = 0.5
    """Weight on the heading error to the goal's: 1 - its cosine."""
    w_velocity: float = 0.1
    """Weight on a slow body, so it stops at the goal."""
    w_angular_velocity: float = 0.01
    """Weight on slow turning (rad/s)."""
    w_control: float = 0.1
    """Weight on thrusts near hover."""
    goal_radius: float = 0.2
    """Distance (m) within which the goal counts as reached (with the heading within 0.5 rad)."""
    new_goal_on_reach: bool = True
    """Move the goal to a random pose whenever it is reached (turn off to place goals by hand)."""


class Quadrotor(DynamicsTask[QuadrotorConfig]):
    """State [position (3), orientation quaternion w, x, y, z (4), world velocity (3), body angular
    velocity (3)]; controls: the four rotors' thrusts as fractions of 13 N (hover 0.25)."""

    lower_is_better = ("final_distance", "crashes")
    focus_body = "quadrotor"
    scene_xml = """<geom name="floor" type="plane" size="3 3 0.1" rgba="0.85 0.85 0.85 1"/>
    <body name="goal" mocap="true" pos="1 0 1.2">
      <geom type="sphere" size="0.06" rgba="0.2 0.8 0.2 0.6" contype="0" conaffinity="0"/>
      <geom type="box" size="0.12 0.01 0.01" pos="0.12 0 0" rgba="0.2 0.8 0.2 0.6" contype="0" conaffinity="0"/>
    </body>"""  # noqa: E501
    robot_xml = """<body name="quadrotor">
      <freejoint/>
      <geom type="box" size="0.12 0.05 0.03" rgba="0.3 0.3 0.35 1"/>
      <geom type="box" size="0.2 0.012 0.01" euler="0 0 52" rgba="0.3 0.3 0.35 1"/>
      <geom type="box" size="0.2 0.012 0.01" euler="0 0 -52" rgba="0.3 0.3 0.35 1"/>
      <geom type="cylinder" size="0.1 0.005" pos="-0.14 -0.18 0.02" rgba="0.9 0.4 0.1 0.7"/>
      <geom type="cylinder" size="0.1 0.005" pos="-0.14 0.18 0.02" rgba="0.9 0.4 0.1 0.7"/>
      <geom type="cylinder" size="0.1 0.005" pos="0.14 0.18 0.02" rgba="0.2 0.5 0.9 0.7"/>
      <geom type="cylinder" size="0.1 0.005" pos="0.14 -0.18 0.02" rgba="0.2 0.5 0.9 0.7"/>
    </body>"""
    num_traces = 1

    def __init__(self) -> None:
        super().__init__(nx=13, control_range=[[0.0, 1.0]] * 4, dt=DT)
        self.goals_reached = 0
        self.reset()

    def dynamics(self, states: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
        """Semi-implicit Euler step of the rigid body: (N, 13) states, (N, 4) controls -> (N,
        13)."""
        position, quat, velocity, omega = (
            states[:, :3],
            states[:, 3:7],
            states[:, 7:10],
            states[:, 10:13],
        )
        thrust = MAX_THRUST * controls
        torque = np.stack(
            [thrust @ ROTORS[:, 1], -(thrust @ ROTORS[:, 0]), thrust @ YAW_MOMENT], axis=1
        )
        omega = omega + dt * (torque - np.cross(omega, INERTIA * omega)) / INERTIA
        w, x, y, z = quat.T
        p, q, r = omega.T
        quat = quat + 0.5 * dt * np.stack(
            [
                -x * p - y * q - z * r,
                w * p + y * r - z * q,
                w * q + z * p - x * r,
                w * r + x * q - y * p,
            ],
            axis=1,
        )
        quat = quat / np.linalg.norm(quat, axis=1, keepdims=True)
        acceleration = z_axis(quat) * (thrust.sum(1) / MASS)[:, None]
        acceleration[:, 2] -= GRAVITY
        velocity = velocity + dt * acceleration
        return np.concatenate([position + dt * velocity, quat, velocity, omega], axis=1)

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: QuadrotorConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        goal = mocap_pose(self.model, system_metadata, "mocap_pos")[..., 0, :]
        goal_yaw = yaw_of(mocap_pose(self.model, system_metadata, "mocap_quat")[..., 0, :])
        quat = states[..., 3:7]
        return -(
            config.w_position * smooth_l1_norm(states[..., :3] - goal, 0.1).sum(-1)
            + config.w_upright * (1.0 - z_axis(quat)[..., 2]).sum(-1)
            + config.w_yaw * (1.0 - np.cos(yaw_of(quat) - goal_yaw)).sum(-1)
            + config.w_velocity * np.square(states[..., 7:10]).sum((-2, -1))
            + config.w_angular_velocity * np.square(states[..., 10:13]).sum((-2, -1))
            + config.w_control * np.square(controls - HOVER).sum((-2, -1))
            + 100.0 * np.maximum(-states[..., 2], 0.0).sum(-1)  # below the floor
        )

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """Hover thrust on every rotor."""
        return np.full(4, HOVER)

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """Hover thrust on every rotor (a real drone would land)."""
        return np.full(4, HOVER)

    def draw_qpos(self, states: np.ndarray) -> np.ndarray:
        """(B, 7) the drawn body's free joint: position and quaternion."""
        return states[:, :7]

    def trace_points(self, states: np.ndarray) -> np.ndarray:
        """(..., 1, 3) the body's position."""
        return states[..., None, :3]

    def initial_state(self) -> np.ndarray:
        """At rest 1 m up near the centre, level, facing a random way."""
        yaw = self.rng.uniform(-np.pi, np.pi)
        position = [*self.rng.uniform(-0.3, 0.3, 2), 1.0]
        return np.array([*position, np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2), *np.zeros(6)])

    def reset(self) -> None:
        """The quadrotor at `initial_state`, a random goal pose, the goal count at 0."""
        super().reset()
        self.goals_reached = 0
        self._new_goal()

    def _new_goal(self) -> None:
        while True:
            goal = self.rng.uniform(GOAL_LOW, GOAL_HIGH)
            if np.linalg.norm(goal - self.state[:3]) > 0.8:
                break
        yaw = self.rng.uniform(-np.pi, np.pi)
        self.data.mocap_pos[0] = goal
        self.data.mocap_quat[0] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]

    def pre_sim_step(self) -> None:
        """Count a reached goal pose and draw the next one."""
        if self.config.new_goal_on_reach:
            state, data = self.state, self.data
            near = np.linalg.norm(state[:3] - data.mocap_pos[0]) < self.config.goal_radius
            if near and np.cos(yaw_of(state[3:7]) - yaw_of(data.mocap_quat[0])) > np.cos(
                YAW_TOLERANCE
            ):
                self.goals_reached += 1
                self._new_goal()

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """goals_reached and goals_per_minute (counted on this plant task); crashes: steps below the
        floor; final_distance (m) to the goal in force at the end."""
        duration = log.times[-1] - log.times[0] + DT
        return {
            "goals_reached": float(self.goals_reached),
            "goals_per_minute": float(60.0 * self.goals_reached / duration),
            "crashes": float(np.count_nonzero(log.states[:, 2] < 0.0)),
            "final_distance": float(np.linalg.norm(log.states[-1, :3] - self.data.mocap_pos[0])),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """At least one goal reached, never below the floor."""
        return bool(metrics["goals_reached"] >= 1 and metrics["crashes"] == 0)
