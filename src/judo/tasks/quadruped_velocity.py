"""Quadruped velocity tracking: the Go1-class quadruped follows a commanded base velocity (forward,
sideways, yaw rate), planned directly in its 12 joint targets. The command is redrawn every few
seconds of sim time.

Its reward is what `python -m judo gait-search` teaches the shipped locomotion policy on
(judo.learning.policy_search), and `policy_observation` gives what such a policy sees on the robot
(proprioception, the command and the gait's clock).
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.policy import PolicyError
from judo.core.task import EpisodeLog
from judo.tasks.quadruped import MODEL_PATH, QuadrupedBase, QuadrupedBaseConfig

COMMAND_KEY = "velocity_command"
"""The system metadata key under which the plant publishes its (3,) command [vx, vy, yaw rate]."""
TRACKED_ERROR = 0.2
"""Horizontal velocity error (m/s) under which a step counts as tracked (`tracked_fraction`)."""
AVERAGE_WINDOW = 0.5
"""Seconds over which `metrics` averages the velocities before comparing them with the command: a
trotting trunk sways sideways and yaws back and forth within each stride (0.4 s), which no command
asks to remove."""
OBSERVATION = (
    "12 joint angles minus the standing pose (rad), 12 joint velocities (rad/s), trunk "
    "angular velocity in the "
    "trunk frame (3, rad/s, what a gyro reads), gravity's direction in the trunk frame (3), "
    "the command [vx, vy, "
    "yaw rate] (3), the gait clock [cos, sin] of 2 pi 2.5 Hz t (2)"
)
"""What `QuadrupedVelocity.policy_observation` holds, in order: 35 values. Not the previous action:
a policy cloned with it copied it (its joint targets moved 0.007 rad a step against the MPC's 0.06,
and it fell 12 times in 20 s)."""
OBSERVATION_COLUMNS = {
    "command": np.arange(30, 33),
    "clock": np.arange(33, 35),
    "gyro_and_gravity": np.arange(24, 30),
}
"""Where the gait policy (judo.learning.gait_policy) reads its inputs in OBSERVATION."""


@slider("max_forward", 0.0, 1.5, 0.05)
@slider("max_backward", 0.0, 1.0, 0.05)
@slider("max_sideways", 0.0, 1.0, 0.05)
@slider("max_yaw_rate", 0.0, 2.0, 0.05)
@slider("resample_period", 0.5, 20.0, 0.5)
@slider("manual_vx", -1.0, 1.5, 0.05)
@slider("manual_vy", -1.0, 1.0, 0.05)
@slider("manual_yaw_rate", -2.0, 2.0, 0.05)
@slider("w_yaw_rate", 0.0, 10.0, 0.1)
@dataclass
class QuadrupedVelocityConfig(QuadrupedBaseConfig):
    """Quadruped velocity-tracking weights and the command's range. Commands are in the trunk's
    heading frame."""

    max_forward: float = 0.6
    """Largest forward speed (m/s) a drawn command asks for."""
    max_backward: float = 0.3
    """Largest backward speed (m/s) a drawn command asks for."""
    max_sideways: float = 0.3
    """Largest sideways speed (m/s), either way, a drawn command asks for."""
    max_yaw_rate: float = 0.8
    """Largest turning rate (rad/s), either way, a drawn command asks for."""
    resample_period: float = 4.0
    """Seconds of sim time between two drawn commands."""
    manual: bool = False
    """Follow the manual_* command below instead of drawn ones (set the command by hand in the
    GUI)."""
    manual_vx: float = 0.3
    """The manual command's forward speed (m/s)."""
    manual_vy: float = 0.0
    """The manual command's sideways speed (m/s, to the left)."""
    manual_yaw_rate: float = 0.0
    """The manual command's turning rate (rad/s, counter-clockwise)."""
    w_upright: float = 20.0
    """Weight on the trunk tilting (1 - cos of its angle from vertical). 20 against the goal task's
    10: mppi at 20 Hz and 25 ms (seeds 0-4, 10 s) fell 3 times over the 5 episodes at 10, never at
    20 or 30, with about the same velocity error at 20 (0.256 against 0.254 m/s) and a worse one at
    30 (0.280)."""
    w_velocity: float = 6.0
    """Weight on the trunk's horizontal velocity differing from the command's (squared, m^2/s^2). 6
    against the goal task's 2: mppi's velocity error (seed 0, 12 s) was 0.28 m/s at 4 and 0.23 at
    10, but at 10 the trunk crouched to within 4 mm of a fall."""
    w_yaw_rate: float = 2.0
    """Weight on the trunk's yaw rate differing from the command's (squared, rad^2/s^2)."""

    def validate(self) -> None:
        super().validate()
        for name in ("max_forward", "max_backward", "max_sideways", "max_yaw_rate"):
            require(
                getattr(self, name) >= 0,
                f"{type(self).__name__}.{name} must be at least 0, got {getattr(self, name)}",
            )
        require(
            self.resample_period > 0,
            f"{type(self).__name__}.resample_period must be above 0 s, got {self.resample_period}",
        )


def draw_command(config: QuadrupedVelocityConfig, rng: np.random.Generator) -> np.ndarray:
    """(3,) a command [vx, vy, yaw rate] drawn uniformly from `config`'s ranges."""
    return np.array(
        [
            rng.uniform(-config.max_backward, config.max_forward),
            rng.uniform(-config.max_sideways, config.max_sideways),
            rng.uniform(-config.max_yaw_rate, config.max_yaw_rate),
        ]
    )


def trailing_mean(values: np.ndarray, window: int) -> np.ndarray:
    """(S,) the mean of (S,) `values` over the `window` entries up to each (fewer at the start)."""
    sums = np.cumsum(np.concatenate([[0.0], values]))
    ends = np.arange(1, len(values) + 1)
    starts = np.maximum(ends - window, 0)
    return (sums[ends] - sums[starts]) / (ends - starts)


def yaw_of(quat: np.ndarray) -> np.ndarray:
    """(...,) the heading (rad) of (..., 4) unit quaternions [w, x, y, z]: the yaw of their x
    axis."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class QuadrupedVelocity(QuadrupedBase[QuadrupedVelocityConfig]):
    """Track the command [vx, vy, yaw rate]: vx and vy in the trunk's heading frame (m/s), the yaw
    rate (rad/s).

    The plant draws a command from the config's ranges every `resample_period` s of sim time with
    its own `rng` (or follows the manual one) and publishes it as system metadata
    "velocity_command"; the reward reads it there. `post_sim_step` counts falls and stands the robot
    up where it fell.
    """

    config_cls = QuadrupedVelocityConfig
    lower_is_better = ("falls", "velocity_error", "yaw_rate_error")
    # collect keeps each step's command, which distill's observation needs
    recorded_metadata = (COMMAND_KEY,)

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self.command = np.zeros(3)
        """(3,) the command in force on this plant."""
        self.command_log: list[tuple[float, np.ndarray]] = []
        """(time, (3,) command) each time the plant's command changed, for `metrics`."""
        self._next_draw = 0.0
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: QuadrupedVelocityConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost, (num_rollouts,): `base_cost`, the horizontal velocity's
        difference from the command turned into the world by each step's heading, and the yaw
        rate's."""
        command = self.command_from(system_metadata)
        yaw = self.heading(sensors)
        cos, sin = np.cos(yaw), np.sin(yaw)
        wanted = np.stack(
            [cos * command[0] - sin * command[1], sin * command[0] + cos * command[1]], axis=-1
        )
        yaw_rate = states[..., self.model.nq + 5]  # the free joint's angular velocity, trunk frame
        cost = (
            self.base_cost(states, sensors, controls, config)
            + self.velocity_cost(sensors, wanted, config)
            + config.w_yaw_rate * np.square(yaw_rate - command[2])
        )
        return -cost.mean(-1)

    def command_from(self, system_metadata: dict[str, Any] | None) -> np.ndarray:
        """(3,) the command the system published, or this task's own where it published none."""
        if system_metadata is not None and COMMAND_KEY in system_metadata:
            return np.asarray(system_metadata[COMMAND_KEY], dtype=float)
        return self.command

    def reset(self) -> None:
        """Standing at the origin facing +x, at rest; a first command drawn (or the manual one);
        counters at zero."""
        self.stand_at(0.0, 0.0, 0.0)
        self.data.time = 0.0
        self.falls = 0
        self.command_log = []
        self._next_draw = 0.0
        self.pre_sim_step()

    def pre_sim_step(self) -> None:
        """Follow the manual command, or draw a new one when `resample_period` has passed since the
        last."""
        config, now = self.config, float(self.data.time)
        if config.manual:
            command = np.array([config.manual_vx, config.manual_vy, config.manual_yaw_rate])
        elif now >= self._next_draw:
            command = draw_command(config, self.rng)
            self._next_draw = now + config.resample_period
        else:
            return
        if not self.command_log or not np.array_equal(command, self.command):
            self.command = command
            self.command_log.append((now, command.copy()))

    def get_sim_metadata(self) -> dict[str, Any]:
        """{"velocity_command": (3,) the command in force}, for the planner's reward."""
        return {COMMAND_KEY: self.command.copy()}

    def readout(self, system_metadata: dict[str, Any]) -> str | None:
        """The command being tracked, e.g. 'command: forward 0.50 m/s · left 0.00 m/s · turn 0.30
        rad/s'."""
        if COMMAND_KEY not in system_metadata:
            return None
        vx, vy, yaw = (float(v) for v in system_metadata[COMMAND_KEY])
        return f"command: forward {vx:.2f} m/s · left {vy:.2f} m/s · turn {yaw:.2f} rad/s"

    def commands_at(self, times: np.ndarray) -> np.ndarray:
        """(S, 3) the command in force at each of (S,) plant `times` (s), from `command_log`."""
        if not self.command_log:
            return np.tile(self.command, (len(times), 1))
        starts = np.array([t for t, _ in self.command_log])
        commands = np.array([c for _, c in self.command_log])
        # A step's row is logged after it; the command of that step is the one in force when it
        # began.
        return commands[
            np.maximum(
                np.searchsorted(starts, times - self.sim_model.opt.timestep, side="right") - 1, 0
            )
        ]

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """velocity_error: mean horizontal velocity error (m/s) in the heading frame;
        yaw_rate_error: mean absolute yaw-rate error (rad/s); tracked_fraction: share of steps with
        a velocity error under 0.2 m/s; falls. Each step compares the command in force with the
        velocities averaged over the AVERAGE_WINDOW before it."""
        nq = self.sim_model.nq
        commands = self.commands_at(log.times)
        yaw = yaw_of(log.states[:, 3:7])
        vx, vy = log.states[:, nq], log.states[:, nq + 1]
        window = max(1, round(AVERAGE_WINDOW / float(self.sim_model.opt.timestep)))
        forward = trailing_mean(np.cos(yaw) * vx + np.sin(yaw) * vy, window)
        sideways = trailing_mean(-np.sin(yaw) * vx + np.cos(yaw) * vy, window)
        yaw_rate = trailing_mean(log.states[:, nq + 5], window)
        error = np.hypot(forward - commands[:, 0], sideways - commands[:, 1])
        return {
            "velocity_error": float(error.mean()),
            "yaw_rate_error": float(np.abs(yaw_rate - commands[:, 2]).mean()),
            "tracked_fraction": float((error < TRACKED_ERROR).mean()),
            "falls": float(self.falls),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: no fall and the velocity tracked on most steps."""
        return bool(metrics["falls"] == 0 and metrics["tracked_fraction"] >= 0.5)

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 35) what a locomotion policy sees (OBSERVATION), from (B, nq + nv) states, the published command and
        the (B, nsensordata) sensors' "clock" (the sim time); `previous_actions` is not used
        (OBSERVATION says why). The rest is read from the states: the trunk-frame angular velocity
        is what the IMU's gyro reads, and gravity's direction what its orientation gives, so the
        policy needs no simulator-only value."""  # noqa: E501
        states = np.atleast_2d(np.asarray(states, dtype=float))
        if sensors is None:
            raise PolicyError(
                "quadruped_velocity's policy observation needs the sensors, for the gait clock"
            )
        commands = np.broadcast_to(self.command_from(system_metadata), (len(states), 3))
        times = np.atleast_2d(np.asarray(sensors, dtype=float))[:, self._clock]
        return self.locomotion_observation(commands, states, previous_actions, times)
