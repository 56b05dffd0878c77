"""A ROS 2 bridge's MCAP log as arrays on the robot's clock (`BridgeLog`, which
`judo.ros2.mcap_read.read_bridge_log` reads): its rows, commands and applied commands, the command
applied at a time (`BridgeLog.actions_at`), and the runs of rows a rollout is compared with step by
step (`BridgeLog.segments`, `step_runs`, `grid_runs`); the ROS 2 types of the messages it is read
from; and `BridgeLogError`, for a log that cannot be read or compared. It needs no DDS and no
`mcap`."""

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from judo.core.errors import JudoError

JOINT_STATE = "sensor_msgs/msg/JointState"
COMMANDS = "std_msgs/msg/Float64MultiArray"
ODOMETRY = "nav_msgs/msg/Odometry"
POSES = "geometry_msgs/msg/PoseArray"
STAMP_TOLERANCE = 1e-6
"""Seconds within which an applied command's stamp is the row's own (a command applied from the
row's time on is in force for the step after it, not the step that ended there); stamps are whole
nanoseconds."""
MAX_GAP_STEPS = 100
"""The most model steps between two joint states of one run compared every k steps
(`BridgeLog.grid_runs`)."""


class BridgeLogError(JudoError):
    """An MCAP file that is not a bridge log judo can read for this task."""


@dataclass
class BridgeLog:
    """A bridge log as arrays on the robot's clock.

    Attributes:
        path: the file.
        task: the task's registered name (the log's own, else the one given).
        times: (S,) each row's JointState header stamp, seconds, increasing.
        qpos, qvel: (S, nq), (S, nv) the plant's state at each row; qvel NaN where the JointState
            had no velocities.
        actions: (S, nu) the command applied during the plant step that ended at each
            row (`actions_at`); NaN before the first command.
        mocap_pos: (S, 3 * nmocap) the latest mocap positions at each row, or None without a
            PoseArray.
        command_times: (C,) each command's time on the robot's clock, seconds.
        commands: (C, nu) the commands, in the order judo wrote them.
        timestep: the plant model's step, seconds.
        topics: {"joint_states", "commands", "applied", ...: the topic read}.
        applied_times: (A,) the robot's time each applied command took effect (the start of the
            first step it was in force), seconds, increasing; empty where the log holds no applied
            commands.
        applied: (A, nu) the commands the robot applied, as it reported them.
    """

    path: Path
    task: str
    times: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    actions: np.ndarray
    mocap_pos: np.ndarray | None
    command_times: np.ndarray
    commands: np.ndarray
    timestep: float
    topics: dict[str, str]
    applied_times: np.ndarray
    applied: np.ndarray

    @property
    def source(self) -> str:
        """ "applied" where the rows are paired with the commands the robot reported applying, else
        "sent"."""
        return "applied" if len(self.applied) else "sent"

    def step_runs(self, step: float, needed: bool = True) -> list[slice]:
        """`segments(step)`, or BridgeLogError (one line naming the file) for a log that cannot be
        compared with a rollout of `step` seconds a step: without commands, without velocities, or
        (where `needed`) no two rows `step` apart."""
        if not len(self.commands) and not len(self.applied):
            raise BridgeLogError(
                f"{self.path}: no {COMMANDS} on {self.topics['commands']}; sysid needs the "
                "commands the robot applied"
            )
        if np.isnan(self.qvel).all():
            raise BridgeLogError(
                f"{self.path}: its joint states carry no velocities; sysid fits qpos and qvel"
            )
        runs = list(self.segments(step))
        if not runs and needed:
            spacing = float(np.median(np.diff(self.times))) if len(self.times) > 1 else math.nan
            raise BridgeLogError(
                f"{self.path}: no two joint states one model step ({step:g} s) apart with a "
                "command in force (they "
                f"are {spacing:.3g} s apart); the robot must publish one each step (python "
                "-m judo plant --rate-hz "
                f"{1 / step:g})"
            )
        return runs

    def grid_runs(self, step: float) -> list[tuple[slice, np.ndarray]]:
        """The runs of at least two rows, each row a whole number of steps (1 to MAX_GAP_STEPS,
        within 1e-3 of a step) of `step` seconds after the one before, with a command in force and a
        velocity: (rows, (R,) each row's step count from the run's first row). A robot that
        publishes every k model steps (a 50 Hz driver under a 0.01 s model: k = 2) gives runs with
        offsets 0, k, 2k, ...; a row the bridge missed is a gap of more steps, not the run's end.
        BridgeLogError (one line naming the file) as `step_runs`, where no two rows are a whole
        number of steps apart."""
        self.step_runs(step, needed=False)
        gaps = np.diff(self.times) / step
        whole = np.round(gaps)
        usable = np.zeros(len(self.times), bool)
        usable[1:] = (np.abs(gaps - whole) < 1e-3) & (whole >= 1) & (whole <= MAX_GAP_STEPS)
        usable[1:] &= np.isfinite(self.actions[1:]).all(axis=1)
        usable &= np.isfinite(self.qvel).all(axis=1)
        runs, start = [], 0
        for row in range(1, len(self.times) + 1):
            if row == len(self.times) or not usable[row]:
                if row - start >= 2:
                    offsets = np.concatenate([[0], np.cumsum(whole[start : row - 1])]).astype(int)
                    runs.append((slice(start, row), offsets))
                start = row
        if not runs:
            spacing = float(np.median(np.diff(self.times))) if len(self.times) > 1 else math.nan
            raise BridgeLogError(
                f"{self.path}: no two joint states a whole number of model steps ({step:g} "
                "s, at most "
                f"{MAX_GAP_STEPS}) apart with a command in force (they are {spacing:.3g} s "
                "apart); the robot must "
                "publish on the model's step grid (python -m judo plant --rate-hz 100)"
            )
        return runs

    def actions_at(self, times: np.ndarray) -> np.ndarray:
        """(T, nu) the command applied during the plant step that ended at each of `times`: with
        applied commands (`source` "applied"), the latest stamped before it (by more than
        STAMP_TOLERANCE); else the latest command sent at or before it on the robot's clock. NaN
        before the first."""
        times = np.asarray(times, float)
        if len(self.applied):
            return _latest(self.applied_times, self.applied, times - STAMP_TOLERANCE, "left")
        return _latest(self.command_times, self.commands, times + 1e-9, "right")

    def segments(self, step: float | None = None) -> Iterator[slice]:
        """The runs of at least two rows, each row `step` seconds (default: one plant step) after
        the one before, with a command in force and a velocity: the rows a rollout from a run's
        first row is compared with step by step (a JointState the bridge missed ends a run)."""
        steps = np.diff(self.times) / (self.timestep if step is None else step)
        usable = np.zeros(len(self.times), bool)
        usable[1:] = (np.abs(steps - 1.0) < 1e-3) & np.isfinite(self.actions[1:]).all(axis=1)
        usable &= np.isfinite(self.qvel).all(axis=1)
        start = 0
        for row in range(1, len(self.times) + 1):
            if row == len(self.times) or not usable[row]:
                if row - start >= 2:
                    yield slice(start, row)
                start = row


def _latest(
    stamps: np.ndarray, values: np.ndarray, at: np.ndarray, side: Literal["left", "right"]
) -> np.ndarray:
    """(T, nu) the row of the (N, nu) `values` with the latest of the (N,) increasing `stamps`
    before each of the (T,) `at` (`side` "right": at or before), NaN before the first."""
    out = np.full((len(at), values.shape[1]), np.nan)
    index = np.searchsorted(stamps, at, side=side) - 1
    out[index >= 0] = values[index[index >= 0]]
    return out
