"""Car: a kinematic bicycle drives to goals among round obstacles, on its own numpy dynamics (not
MuJoCo).

The vehicle is the F1TENTH 1/10-scale car with the default parameters of f1tenth_gym (O'Kelly et
al., "F1TENTH: An Open-source Evaluation Environment for Continuous Control and Reinforcement
Learning", PMLR 123, 2020): axle distances from the centre of mass lf = 0.15875 m and lr = 0.17145
m, steering within +-0.4189 rad, acceleration within +-9.51 m/s^2, speed from -5 to 20 m/s, body
0.58 m x 0.31 m. The kinematic bicycle about the centre of mass is eq. (1) of Kong et al.,
"Kinematic and dynamic vehicle models for autonomous driving control design", IEEE IV 2015.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.configuration.fields import slider
from judo.core.model import mocap_pose
from judo.core.norms import smooth_l1_norm
from judo.core.rollouts.dynamics import DynamicsTask
from judo.core.task import EpisodeLog, TaskConfig

LF, LR = 0.15875, 0.17145
"""Distances (m) from the centre of mass to the front and rear axles (f1tenth_gym)."""
MAX_STEER, MAX_ACCEL = 0.4189, 9.51
"""Steering angle (rad) and acceleration (m/s^2) limits (f1tenth_gym)."""
MIN_SPEED, MAX_SPEED = -5.0, 20.0
"""Speed limits (m/s) (f1tenth_gym)."""
LENGTH, WIDTH = 0.58, 0.31
"""Body size (m) (f1tenth_gym)."""
CAR_RADIUS = 0.2
"""Radius (m) of the disc the car counts as for hitting an obstacle (about half its length)."""
CLEARANCE = 0.1
"""Extra distance (m) the reward keeps from obstacles beyond the car's disc."""
DT = 0.02
"""Step (s): 50 Hz."""
OBSTACLES = np.array(
    [[1.2, 1.0, 0.35], [-1.1, 1.3, 0.3], [-1.3, -1.1, 0.4], [1.0, -1.4, 0.3], [0.0, 2.4, 0.3]]
)
"""(5, 3) obstacles as [x, y, radius] (m)."""
GOAL_SPAN = 2.5
"""New goals are drawn uniformly from [-GOAL_SPAN, GOAL_SPAN]^2 (m), clear of the obstacles."""


def _scene_xml() -> str:
    obstacles = "".join(
        f'<geom name="obstacle{i}" type="cylinder" size="{r} 0.15" pos="{x} {y} 0.15" '
        'rgba="0.55 0.35 0.3 1"/>'
        for i, (x, y, r) in enumerate(OBSTACLES)
    )
    return f"""<geom name="floor" type="plane" size="3.5 3.5 0.1" rgba="0.85 0.85 0.85 1"/>
    {obstacles}
    <body name="goal" mocap="true" pos="1.5 0 0.01">
      <geom type="cylinder" size="0.15 0.01" rgba="0.2 0.8 0.2 0.6" contype="0" conaffinity="0"/>
    </body>"""


@slider("w_position", 0.0, 20.0, 0.1)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_obstacle", 0.0, 500.0, 1.0)
@slider("w_control", 0.0, 1.0, 0.001)
@slider("goal_radius", 0.05, 1.0, 0.05)
@dataclass
class CarConfig(TaskConfig):
    """Car reward weights and goal rule. The goal is the mocap body "goal": drag it in the GUI."""

    w_position: float = 5.0
    """Weight on the distance (m) from the car's centre to the goal."""
    w_velocity: float = 0.05
    """Weight on a slow car, so it stops on the goal instead of circling it."""
    w_obstacle: float = 300.0
    """Weight on how deep (m) the car's disc, 10 cm larger for clearance, reaches into an
    obstacle."""
    w_control: float = 0.001
    """Weight on small controls (fractions of their limits)."""
    goal_radius: float = 0.2
    """Distance (m) within which the goal counts as reached."""
    new_goal_on_reach: bool = True
    """Move the goal to a random free spot whenever the car reaches it (turn off to place goals by
    hand)."""


class Car(DynamicsTask[CarConfig]):
    """State [x, y, heading, speed] of the centre of mass; controls [acceleration, steering angle]
    as fractions of their limits (9.51 m/s^2, 0.4189 rad), so one sampling width suits both."""

    lower_is_better = ("final_distance", "collision_fraction")
    focus_body = "car"
    scene_xml = _scene_xml()
    robot_xml = f"""<body name="car">
      <joint name="car_x" type="slide" axis="1 0 0"/>
      <joint name="car_y" type="slide" axis="0 1 0"/>
      <joint name="car_heading" type="hinge" axis="0 0 1"/>
      <geom type="box" size="{LENGTH / 2} {WIDTH / 2} 0.05" pos="0 0 0.08" rgba="0.2 0.4 0.9 1"/>
      <geom type="box" size="0.04 {WIDTH / 2 - 0.02} 0.03" pos="{LF} 0 0.15" rgba="0.9 0.9 0.2 1"/>
    </body>"""
    num_traces = 1

    def __init__(self) -> None:
        super().__init__(nx=4, control_range=[[-1.0, 1.0], [-1.0, 1.0]], dt=DT)
        self.goals_reached = 0
        self.reset()

    def dynamics(self, states: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
        """Explicit Euler step of the kinematic bicycle: (N, 4) states, (N, 2) controls -> (N,
        4)."""
        x, y, heading, speed = states.T
        slip = np.arctan(LR / (LF + LR) * np.tan(MAX_STEER * controls[:, 1]))
        direction = heading + slip
        return np.stack(
            [
                x + dt * speed * np.cos(direction),
                y + dt * speed * np.sin(direction),
                heading + dt * speed / LR * np.sin(slip),
                np.clip(speed + dt * MAX_ACCEL * controls[:, 0], MIN_SPEED, MAX_SPEED),
            ],
            axis=1,
        )

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: CarConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        goal = mocap_pose(self.model, system_metadata, "mocap_pos")[..., 0, :2]
        position = states[..., :2]
        return -(
            config.w_position * smooth_l1_norm(position - goal, 0.1).sum(-1)
            + config.w_velocity * np.square(states[..., 3]).sum(-1)
            + config.w_obstacle * penetration(position, CAR_RADIUS + CLEARANCE).sum(-1)
            + config.w_control * np.square(controls).sum((-2, -1))
        )

    def draw_qpos(self, states: np.ndarray) -> np.ndarray:
        """(B, 3) the drawn car's [x, y, heading]."""
        return states[:, :3]

    def trace_points(self, states: np.ndarray) -> np.ndarray:
        """(..., 1, 3) the car's centre, 5 cm above the floor."""
        points = np.full((*states.shape[:-1], 1, 3), 0.05)
        points[..., 0, :2] = states[..., :2]
        return points

    def initial_state(self) -> np.ndarray:
        """At rest near the centre, facing a random way."""
        return np.array([*self.rng.uniform(-0.3, 0.3, 2), self.rng.uniform(-np.pi, np.pi), 0.0])

    def reset(self) -> None:
        """The car at `initial_state`, a random goal clear of the obstacles, the goal count at 0."""
        super().reset()
        self.goals_reached = 0
        self._new_goal()

    def _new_goal(self) -> None:
        while True:
            goal = self.rng.uniform(-GOAL_SPAN, GOAL_SPAN, 2)
            far = np.linalg.norm(goal - self.state[:2]) > 1.0
            if far and penetration(goal[None], margin=0.3)[0] == 0.0:
                break
        self.data.mocap_pos[0, :2] = goal

    def pre_sim_step(self) -> None:
        """Count a reached goal and draw the next one."""
        if self.config.new_goal_on_reach:
            if (
                np.linalg.norm(self.state[:2] - self.data.mocap_pos[0, :2])
                < self.config.goal_radius
            ):
                self.goals_reached += 1
                self._new_goal()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """Brake to a stop, wheels straight."""
        return np.array([-np.clip(state[3] / (DT * MAX_ACCEL), -1.0, 1.0), 0.0])

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """goals_reached and goals_per_minute (counted on this plant task); collision_fraction: the
        share of steps with the car's disc inside an obstacle; final_distance (m) to the goal in
        force at the end."""
        duration = log.times[-1] - log.times[0] + DT
        return {
            "goals_reached": float(self.goals_reached),
            "goals_per_minute": float(60.0 * self.goals_reached / duration),
            "collision_fraction": float(np.mean(penetration(log.states[:, :2]) > 0.0)),
            "final_distance": float(
                np.linalg.norm(log.states[-1, :2] - self.data.mocap_pos[0, :2])
            ),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """At least one goal reached and never inside an obstacle."""
        return bool(metrics["goals_reached"] >= 1 and metrics["collision_fraction"] == 0.0)


def penetration(positions: np.ndarray, margin: float = CAR_RADIUS) -> np.ndarray:
    """(...,) how deep (m) a disc of radius `margin` at (..., 2) `positions` reaches into the
    deepest obstacle."""
    offsets = positions[..., None, :] - OBSTACLES[:, :2]
    depth = OBSTACLES[:, 2] + margin - np.sqrt(np.square(offsets).sum(-1))
    return np.maximum(depth, 0.0).max(-1)
