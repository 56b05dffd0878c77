"""The estimator's side of the closed loop: the plant's now, the age of each measured value, and
the estimator fed every served action and run on each raw reading.

`ClosedLoop` holds one `Estimation`: where it has an estimator, `read` turns the System's raw
reading into the state planned from and `advance` feeds `controls` the action served; a reset of
the plant restarts it.
"""

import dataclasses

import numpy as np

from judo.core.estimator import ControlHistory, Estimator
from judo.core.reading import SystemState
from judo.core.task import Task
from judo.loop.system import System


class Estimation:
    """Runs `estimator` on the raw readings of `system`, as of the plant's now.

    Args:
        system: the plant; its `time`, where it has one, is the plant's now (a reading may be late).
        task: the planning task: its measured sensors and command size.
        estimator: turns each raw reading into the state planned from; None: the reading is used
            as it is.
    """

    def __init__(self, system: System, task: Task, estimator: Estimator | None) -> None:
        self.system, self.estimator = system, estimator
        self.controls = ControlHistory(task.command_size)  # every served action, fed by the loop
        self._num_measured = len(task.measured_sensors)
        self._started = False

    def restart(self) -> None:
        """Start the estimator afresh from the next reading (after a reset of the plant)."""
        self._started = False
        self.controls.clear()

    def plant_time(self, raw: SystemState) -> float:
        """The plant's now: the System's `time` where it has one (its readings may be late), else
        the reading's."""
        now = getattr(self.system, "time", None)
        return float(now) if isinstance(now, int | float) else raw.time

    def measured_age(self, raw: SystemState) -> np.ndarray:
        """(k,) seconds between taking each measured sensor's value in `raw` (its metadata's
        "sensor_times", else its time) and the plant's now."""
        stamps = np.asarray(raw.metadata.get("sensor_times", raw.time), dtype=float)
        return self.plant_time(raw) - np.broadcast_to(stamps, (self._num_measured,))

    def estimate(self, raw: SystemState) -> SystemState:
        """The estimator's state from `raw` as of the plant's now (started from the first reading
        after a restart); the loop calls it only where it has an estimator."""
        assert self.estimator is not None
        now = self.plant_time(raw)
        if not self._started:
            self.estimator.reset(raw)
            self._started = True
        return dataclasses.replace(self.estimator.update(raw, now, self.controls), time=now)
