"""The "state" estimator: the reading's full state, passed through as the estimate."""

from dataclasses import dataclass

import numpy as np

from judo.core.estimator import (
    ControlHistory,
    Estimator,
    EstimatorConfig,
    ReadingError,
    estimate_of,
)
from judo.core.reading import SystemState


@dataclass
class StateEstimatorConfig(EstimatorConfig):
    """The pass-through has no settings."""


class StateEstimator(Estimator[StateEstimatorConfig]):
    """Plans from `reading.state` as it is, at `reading.time`: no filtering, no delay
    compensation."""

    config_cls = StateEstimatorConfig

    def reset(self, reading: SystemState) -> None:
        self._check(reading)

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """`reading` itself (state copied), at the time it was taken; `time` and `controls` are not
        used."""
        state = self._check(reading)
        return estimate_of(reading, state.copy(), reading.time)

    def _check(self, reading: SystemState) -> np.ndarray:
        """`reading.state`, or a ReadingError when it is missing or the wrong size."""
        model = self.task.model
        size = model.nq + model.nv
        if reading.state is None:
            raise ReadingError(
                f"the 'state' estimator needs a full state (nq + nv = {size} values), but "
                "the reading has only "
                f"sensors; use the '{self.task.default_estimator}' estimator to estimate the "
                "state from "
                f"{type(self.task).__name__}'s sensors"
            )
        if reading.state.shape != (size,):
            raise ReadingError(
                f"SystemState.state must have shape ({size},), got {reading.state.shape}"
            )
        return reading.state
