"""The Estimator contract: turn the plant's readings into the state a plan starts from.

An estimator sits once between the reading and the plan:

    reading = system.read_state()                      # full state, or measured sensors only
    controls.append(time_applied, action)              # every action, as the plant gets it
    estimate = estimator.update(reading, now, controls) # (nq + nv,) state at plant time `now`
    controller.update_action(estimate.state, estimate.time, estimate.metadata)

Call `update` once per plant step (each new reading); a reading already fused is not fused again, so
a System that holds its readings between samples is fine.
"""

from abc import ABC, abstractmethod
from collections import deque
from dataclasses import dataclass
from typing import Any, ClassVar, Generic, TypeVar, cast

import numpy as np

from judo.core.configuration.config import Config
from judo.core.errors import JudoError
from judo.core.reading import SystemState
from judo.core.task import Task


class ReadingError(JudoError, ValueError):
    """A reading that lacks what the estimator needs (a full state, or measured sensors), or has the
    wrong size."""


@dataclass
class EstimatorConfig(Config):
    """Settings every estimator has (none yet); each estimator's config subclasses it."""


class ControlHistory:
    """The controls applied to the plant over the last `span` seconds, each from the time it took
    effect.

    `append(t, u)` says the (nu,) action `u` is in force from plant time `t` on; `at(t)` gives the
    action in force at `t`. Before the first entry the first entry's action is assumed (zeros when
    empty).
    """

    def __init__(self, nu: int, span: float = 1.0) -> None:
        self.nu, self.span = nu, float(span)
        self._times: deque[float] = deque()
        self._actions: deque[np.ndarray] = deque()

    def append(self, time: float, action: np.ndarray) -> None:
        """Record that the (nu,) `action` is in force from `time` on; drops entries older than
        `span`."""
        action = np.asarray(action, dtype=float).reshape(self.nu).copy()
        while self._times and self._times[-1] >= time - 1e-12:  # a correction of the same instant
            self._times.pop()
            self._actions.pop()
        self._times.append(float(time))
        self._actions.append(action)
        while len(self._times) > 1 and self._times[1] <= time - self.span:
            self._times.popleft()
            self._actions.popleft()

    def at(self, time: float) -> np.ndarray:
        """(nu,) the action in force at plant `time` (a copy)."""
        if not self._times:
            return np.zeros(self.nu)
        chosen = self._actions[0]
        for t, action in zip(self._times, self._actions, strict=True):
            if t > time + 1e-9:
                break
            chosen = action
        return chosen.copy()

    def latest(self) -> tuple[float, np.ndarray] | None:
        """(time, (nu,) action) of the newest entry (the action a copy), or None when empty."""
        return (self._times[-1], self._actions[-1].copy()) if self._times else None

    def clear(self) -> None:
        """Forget every control (after a plant reset)."""
        self._times.clear()
        self._actions.clear()


ConfigT = TypeVar("ConfigT", bound=EstimatorConfig)


class Estimator(ABC, Generic[ConfigT]):
    """Estimates the planning model's (nq + nv,) state from a System's readings.

    Subclass it as `class MyEstimator(Estimator[MyConfig])`; register it
    with `judo.register_estimator`.

    Attributes:
        task: the task whose planning model (`task.model`) and `measured` layout the estimator uses;
            it never reads `task.data` (that is the plant's).
        config: the live config; edits take effect at the next update.
    """

    config_cls: ClassVar[type[EstimatorConfig]] = EstimatorConfig

    def __init__(self, task: Task, config: ConfigT | None = None) -> None:
        self.task = task
        # config_cls is the class named in Estimator[ConfigT]; a ClassVar cannot say so.
        self.config: ConfigT = config if config is not None else cast(ConfigT, self.config_cls())

    @abstractmethod
    def reset(self, reading: SystemState) -> None:
        """Start over from `reading` (after a plant reset, or before the first update)."""

    @abstractmethod
    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """Fuse `reading` (taken at `reading.time` <= `time`) and return the estimate at plant
        `time`.

        Args:
            reading: the System's latest reading; state (nq + nv,) or None, sensors (measured size,)
                or None.
            time: the plant time to estimate at (the time the next plan starts from).
            controls: the actions applied to the plant, at least since the oldest reading still to
                fuse.
        Returns:
            SystemState(state=(nq + nv,) estimate, time, metadata=reading.metadata,
            sensors=reading.sensors).
        """

    def covariance(self) -> np.ndarray | None:
        """The (2 nv + na, 2 nv + na) covariance of the last estimate in tangent space, or None if
        not tracked."""
        return None


def check_sensors(task: Task, reading: SystemState, who: str) -> np.ndarray:
    """`reading.sensors` as a float array of the task's measured size, or a ReadingError saying what
    is wrong."""
    name = type(task).__name__
    if not task.measured.size:
        raise ReadingError(
            f"the {who} estimator fuses measured sensors, but {name} declares none; list the "
            "MJCF sensors a "
            f"robot has in {name}.measured_sensors"
        )
    if reading.sensors is None:
        raise ReadingError(
            f"the {who} estimator needs SystemState.sensors (the values of "
            f"{name}.measured_sensors), got None; "
            f"a System that returns the full state goes with the 'state' estimator"
        )
    sensors = np.asarray(reading.sensors, dtype=float)
    if sensors.shape != (task.measured.size,):
        raise ReadingError(
            f"SystemState.sensors must have shape ({task.measured.size},) for "
            f"{name}.measured_sensors "
            f"{task.measured.names}, got {sensors.shape}"
        )
    return sensors


def default_estimator_name(reading: SystemState, task: Task | type[Task]) -> str:
    """ "state" for a reading with a full state, the task's `default_estimator` for one with only
    measured sensors."""
    return "state" if reading.state is not None else task.default_estimator


def estimator_in_force(observe: str, estimator: str | None, task: Task | type[Task]) -> str | None:
    """The estimator a simulated plant of `task` observed as `observe` ("state" or "sensors") runs:
    `estimator` if named, else the task's `default_estimator` for sensors and None (the full state
    as it is) for the state. The one place that decides the default, for the app, evaluate, tune,
    collect, titles and JSON."""
    if estimator is not None:
        return estimator
    return task.default_estimator if observe == "sensors" else None


def estimate_of(reading: SystemState, state: np.ndarray, time: float) -> SystemState:
    """The SystemState an estimator returns: `state` (nq + nv,) at `time`, with the reading's
    metadata."""
    metadata: dict[str, Any] = dict(reading.metadata)
    return SystemState(
        state, float(time), metadata, None if reading.sensors is None else reading.sensors.copy()
    )
