"""`SystemState`, one reading of the plant: the type a `System` returns and an `Estimator` consumes.

It lives in core so that the estimator contract (core/estimator.py) and the estimators do not import
the runtime; `judo.loop.system` uses it beside the `System` interface, and `judo` exports it to
users.
"""

from dataclasses import dataclass, field
from typing import Any

import numpy as np

TIME_TOLERANCE = 1e-9
"""Seconds within which two times count as the same: a reading's stamp, a sample or an update due, a
plan's time and a row's (all sums of timesteps, so equal times may differ in their last bits)."""


@dataclass
class SystemState:
    """One reading of the plant.

    Attributes:
        state: (nq + nv,) [qpos, qvel], or None from a System that measures only sensors.
        time: plant time in seconds at which the measurement was *taken* (so a late reading is known
            as late); with per-sensor times (metadata "sensor_times"), the newest of them.
        metadata: extra values for the controller and reward, e.g. "mocap_pos" (nmocap, 3), and
            "sensor_times" (len(Task.measured_sensors),): when each sensor's value was taken, if
            they differ.
        sensors: (measured size,) values of the task's `measured_sensors`, in
            order (see `Task.measured`), or None when the System measures none.
    """

    state: np.ndarray | None
    time: float
    metadata: dict[str, Any] = field(default_factory=dict)
    sensors: np.ndarray | None = None
