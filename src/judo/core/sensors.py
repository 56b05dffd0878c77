"""Measured sensors: which MJCF sensors a robot has, where their values lie, and per-type settings.

A Task names its measured sensors in `Task.measured_sensors`; `measured_layout` checks the names
against a model and says where each sensor's values lie in `sensordata`. A System that measures only
sensors returns those values, in that order, as `SystemState.sensors`.
"""

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.configuration.config import shown
from judo.core.errors import ConfigError, JudoError, UnknownNameError
from judo.core.model import names

QUATERNION_TYPES = ("framequat", "ballquat")
"""Sensor types whose 4 values are a unit quaternion: their noise and residuals are 3-D rotations
(rad)."""
SENSOR_TYPES = tuple(
    n.removeprefix("mjSENS_").lower() for n in mujoco.mjtSensor.__members__ if n != "mjSENS_USER"
)
"""Every MuJoCo sensor type's MJCF name ("jointpos", "framequat", "gyro", ...)."""
DEFAULT_KEY = "default"
"""The key of a per-type mapping that applies to every sensor type not named in it."""


class InvalidSensorError(JudoError, ValueError):
    """A measured sensor that a robot cannot have (a trace sensor, drawn by the GUI, never
    measured)."""


def sensor_type_name(model: mujoco.MjModel, sensor_id: int) -> str:
    """The MJCF element name of sensor `sensor_id`'s type, e.g. "jointpos", "framequat", "gyro"."""
    return mujoco.mjtSensor(int(model.sensor_type[sensor_id])).name.removeprefix("mjSENS_").lower()


def is_trace_sensor(model: mujoco.MjModel, sensor_id: int) -> bool:
    """True for the GUI's trace sensors: `framepos` sensors whose name contains "trace"."""
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, sensor_id) or ""
    return "trace" in name and int(model.sensor_type[sensor_id]) == mujoco.mjtSensor.mjSENS_FRAMEPOS


@dataclass(frozen=True)
class MeasuredLayout:
    """Where a task's measured sensors lie in a model's `sensordata`, in the task's order.

    Attributes:
        names: (k,) sensor names, as `Task.measured_sensors` lists them.
        types: (k,) each sensor's type name ("jointpos", "framepos", "framequat", ...).
        ids: (k,) sensor ids in the model.
        slices: (k,) each sensor's slice of the measured vector (size,).
        columns: (size,) int columns of `sensordata` that make up the measured vector.
    """

    names: tuple[str, ...]
    types: tuple[str, ...]
    ids: tuple[int, ...]
    slices: tuple[slice, ...]
    columns: np.ndarray

    @property
    def size(self) -> int:
        """Number of measured values (the length of `SystemState.sensors`)."""
        return len(self.columns)

    def read(self, sensordata: np.ndarray) -> np.ndarray:
        """(size,) the measured values out of a (nsensordata,) sensordata row (a copy)."""
        return sensordata[self.columns]


def measured_layout(
    model: mujoco.MjModel, sensor_names: Sequence[str], owner: str
) -> MeasuredLayout:
    """Check `sensor_names` against `model` and lay them out; `owner` (e.g. the task's class) names
    who asked.

    Raises UnknownNameError (listing the sensors a robot could measure) for a name not in the model,
    and InvalidSensorError for a trace sensor or a name listed twice.
    """
    all_names = names(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor)
    measurable = [n for i, n in enumerate(all_names) if n and not is_trace_sensor(model, i)]
    ids, slices, columns, start = [], [], [], 0
    for name in sensor_names:
        sensor_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        if sensor_id < 0:
            raise UnknownNameError(f"measured sensor of {owner}", name, measurable)
        if is_trace_sensor(model, sensor_id):
            raise InvalidSensorError(
                f"{owner} lists trace sensor {name!r} as measured; trace sensors are drawn, "
                "never measured. "
                f"Valid measured sensors are: {', '.join(sorted(measurable)) or '(none)'}"
            )
        if sensor_id in ids:
            raise InvalidSensorError(
                f"{owner} lists measured sensor {name!r} twice; list each sensor once"
            )
        adr, dim = int(model.sensor_adr[sensor_id]), int(model.sensor_dim[sensor_id])
        ids.append(sensor_id)
        slices.append(slice(start, start + dim))
        columns.append(np.arange(adr, adr + dim))
        start += dim
    return MeasuredLayout(
        names=tuple(sensor_names),
        types=tuple(sensor_type_name(model, i) for i in ids),
        ids=tuple(ids),
        slices=tuple(slices),
        columns=np.concatenate(columns) if columns else np.zeros(0, dtype=int),
    )


def per_sensor(
    value: float | Mapping[str, float | None] | None, layout: MeasuredLayout, what: str
) -> list[float | None]:
    """One value per measured sensor, from one value for all or a mapping {sensor type: value}.

    A mapping may hold "default" for the types it does not name. A key must be a MuJoCo sensor type
    (ConfigError lists them, the measured ones first), so one mapping serves tasks that measure
    different types; a type not measured here is ignored. A type neither named nor defaulted gets
    None. `what` names the setting in messages, e.g. "sensor noise".
    """
    if value is None or not isinstance(value, Mapping):
        return [None if value is None else float(value)] * len(layout.names)
    for key in value:
        if key != DEFAULT_KEY and key not in SENSOR_TYPES:
            measured = sorted({*layout.types, DEFAULT_KEY})
            raise ConfigError(
                f"{what}: {key!r} is not a sensor type; valid keys here are: {', '.join(measured)} "
                "(or any other MuJoCo sensor type, as mujoco.mjtSensor names it without its "
                "mjSENS_ prefix, lower case)"
            )
    default = value.get(DEFAULT_KEY)
    picked = [value.get(sensor_type, default) for sensor_type in layout.types]
    return [None if v is None else float(v) for v in picked]


def parse_per_type(items: Sequence[str], what: str) -> float | dict[str, float]:
    """Command-line values like ["100", "framepos=30"] -> {"default": 100.0, "framepos": 30.0}.

    A single bare number gives that float. ConfigError for a value that is not a number, or an "="
    with no TYPE before it ("=0.1").
    """
    parsed: dict[str, float] = {}
    for item in items:
        key, equals, number = item.rpartition("=")
        try:
            if equals and not key:
                raise ValueError("no sensor type before '='")
            parsed[key or DEFAULT_KEY] = float(number)
        except ValueError:
            raise ConfigError(
                f"{what} expects NUMBER or TYPE=NUMBER (e.g. framepos=30), got {shown(item)}"
            ) from None
    if list(parsed) == [DEFAULT_KEY]:
        return parsed[DEFAULT_KEY]
    return parsed
