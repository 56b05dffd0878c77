"""Quadruped navigation over a locomotion policy: the Go1-class quadruped walks to the goal you
drag, but the MPC plans only a base-velocity command [vx, vy, yaw rate] with a few knots. The
locomotion policy judo taught itself (`python -m judo gait-search`: its CEM tunes a clock-driven
trot on quadruped_velocity's reward; models/policies/quadruped_locomotion.onnx, docs/tasks.md) turns
the command into the 12 joint targets at 50 Hz, inside every rollout and on the plant
(judo.core.rollouts.low_level), as the seed paper's Spot tasks plan over an RL policy.

Pass your own as `QuadrupedNavigate(policy_path=...)`: it gets quadruped_velocity's 35-value
observation (with the gait's clock, from each rollout's sim time). The policy runs on onnxruntime, a
core dependency.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.configuration.fields import slider
from judo.core.policies.onnx_policy import OnnxPolicy
from judo.core.rollouts.low_level import LowLevel
from judo.core.task import TaskConfig
from judo.tasks.quadruped import MODEL_PATH, WalkToGoalBase

POLICY_PATH = Path(__file__).parent / "models" / "policies" / "quadruped_locomotion.onnx"
"""The shipped locomotion policy: 35 observations (quadruped_velocity.OBSERVATION) to 12 joint
targets."""
EVERY = 2
"""Physics steps per policy tick: 50 Hz on the model's 0.01 s timestep."""
COMMAND_RANGE = ((-0.3, 0.6), (-0.3, 0.3), (-0.8, 0.8))
"""(3, 2) the commands [vx (m/s), vy (m/s), yaw rate (rad/s)] the MPC may plan: the ranges the
policy was trained on (quadruped_velocity's default max_backward, max_forward, max_sideways,
max_yaw_rate)."""


@slider("speed", 0.0, 0.6, 0.05)
@slider("goal_radius", 0.05, 1.0, 0.05)
@slider("target_height", 0.15, 0.35, 0.005)
@slider("w_height", 0.0, 1000.0, 1.0)
@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_velocity", 0.0, 20.0, 0.1)
@slider("w_goal", 0.0, 20.0, 0.1)
@slider("w_heading", 0.0, 20.0, 0.1)
@slider("w_command", 0.0, 5.0, 0.01)
@dataclass
class QuadrupedNavigateConfig(TaskConfig):
    """Navigation weights and the goal rule. The gait is the policy's: nothing here shapes the
    feet."""

    speed: float = 0.6
    """Walking speed (m/s) to head for the goal with, slowing down within 0.5 m of it: quadruped's,
    and the fastest forward command the policy was taught. Against 0.5, on fresh seeds 2000-2002 x
    20 s, mppi reached 15 goals a minute against 14 at 20 Hz (0 and 25 ms), and 14-16 at 40 Hz; cem
    14-18; no fall anywhere."""
    goal_radius: float = 0.25
    """Horizontal distance (m) from the trunk within which the goal counts as reached."""
    new_goal_on_reach: bool = True
    """Move the goal to a random spot 1 to 2 m away whenever it is reached (turn off to place goals
    by hand)."""
    target_height: float = 0.29
    """Trunk height (m) to hold."""
    w_height: float = 100.0
    """Weight on the trunk's height error (squared, m^2): commands the policy cannot walk at sag the
    trunk."""
    w_upright: float = 10.0
    """Weight on the trunk tilting (1 - cos of its angle from vertical)."""
    w_velocity: float = 2.0
    """Weight on the trunk's horizontal velocity differing from the one towards the goal (squared,
    m^2/s^2)."""
    w_goal: float = 0.2
    """Weight on the trunk's horizontal distance (m) from the goal (smooth L1: quadratic within 0.1
    m)."""
    w_heading: float = 1.0
    """Weight on the trunk facing away from the goal (1 - cos of the yaw error), while farther than
    goal_radius."""
    w_command: float = 0.0
    """Weight on the planned command's size (squared, summed: m^2/s^2 and rad^2/s^2)."""


class QuadrupedNavigate(WalkToGoalBase[QuadrupedNavigateConfig]):
    """Walk to the mocap goal by planning (N, T, 3) velocity commands through the locomotion policy.

    The reward's `controls` are the commands. The goal rule, the goal's cost terms and the metrics
    are quadruped's (WalkToGoalBase), so the two tasks' figures compare directly.
    """

    config_cls = QuadrupedNavigateConfig

    def __init__(
        self,
        model_path: str | Path = MODEL_PATH,
        sim_model_path: str | Path | None = None,
        policy_path: str | Path = POLICY_PATH,
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._low_level = LowLevel(
            OnnxPolicy(
                policy_path, feature="task quadruped_navigate (its shipped locomotion policy)"
            ),
            command_range=COMMAND_RANGE,
            every=EVERY,
            observation=self.locomotion_observation,
        )

    def low_level(self) -> LowLevel:
        return self._low_level

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: QuadrupedNavigateConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,), from (num_rollouts, T, nq + nv) states,
        (num_rollouts, T, nsensordata) sensors and (num_rollouts, T, 3) commands: trunk height and
        tilt, walking towards the goal at `speed`, facing it, its distance, and the commands'
        size."""
        cost = (
            config.w_height * np.square(sensors[..., self._torso + 2] - config.target_height)
            + config.w_upright * (1.0 - sensors[..., self._up + 2])
            + self.goal_cost(sensors, config)
            + config.w_command * np.square(controls).sum(-1)
        )
        return -cost.mean(-1)

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(3,) the first plan commands standing still."""
        return np.zeros(3)

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(3,) command the policy to stand still."""
        return np.zeros(3)
