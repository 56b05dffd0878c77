"""Rehearsed sensing: the simulator seen through a robot's sensors, noisy, late and at their own rates.

    system = SensedSystem(MujocoSystem(task), noise={"default": 0.005, "framequat": 0.017},
                          delay={"framepos": 0.04, "framequat": 0.04}, rate={"default": 100, "framepos": 30})

Each setting is one value for every measured sensor or a mapping {sensor type: value} with an optional
"default" (see `judo.core.sensors.per_sensor`).

Also here, for every command that runs a simulated plant (the app, evaluate, tune and collect): `Sensing`, how
the plant is observed; `observed_plant`, the plant it builds; and `choose_estimator`, the filter between its
readings and the plan. Their command-line flags (`SensingFlags`, `merge_repeated`) are in `judo.cli_shared`.
"""

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.registry import lookup_estimator, make_estimator
from judo.core.errors import ConfigError
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig, ReadingError, default_estimator_name
from judo.core.reading import SystemState
from judo.core.sensors import QUATERNION_TYPES, per_sensor
from judo.core.task import Task
from judo.loop.system import MujocoSystem, System, check_reading

TIME_TOLERANCE = 1e-9
"""Seconds within which a sample counts as due or a reading as arrived."""

PerType = float | Mapping[str, float | None] | None
"""One value for every measured sensor, or {sensor type: value} with an optional "default" key."""


class SensedSystem(System):
    """A simulated plant that serves only its task's measured sensors (`SystemState.state` is None).

    Each measured sensor is sampled at its rate, gets Gaussian noise (a quaternion sensor a random rotation
    of that std per axis, in rad), and is delivered `delay` seconds later, stamped with the time it was
    taken; between samples the last delivered value is held. The reading's `time` is the newest stamp and
    `metadata["sensor_times"]` (k,) holds each sensor's stamp. The sample taken at reset is delivered at once,
    so a loop always has a reading to start from.

    Args:
        system: the simulated plant; its task's `sim_measured` says which sensors are served.
        noise: std per sensor (its unit: rad, m, rad/s, m/s^2); None or 0: noiseless.
        delay: seconds from taking a sample to delivering it; None or 0: at once.
        rate: samples per second; None: every plant step.
        rng: the generator the noise draws from (seed it for a reproducible episode).
    """

    def __init__(
        self,
        system: MujocoSystem,
        noise: PerType = None,
        delay: PerType = None,
        rate: PerType = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.system = system
        self.task = system.task
        self.timestep = system.timestep
        self.layout = self.task.sim_measured
        require(
            self.layout.size > 0,
            f"{type(self.task).__name__} declares no measured sensors; list the MJCF sensors a robot has in "
            f"{type(self.task).__name__}.measured_sensors",
        )
        self.noise = np.array([v or 0.0 for v in per_sensor(noise, self.layout, "sensor noise")])
        self.delay = np.array([v or 0.0 for v in per_sensor(delay, self.layout, "sensor delay")])
        rates = per_sensor(rate, self.layout, "sensor rate")
        for what, values in (("noise", self.noise), ("delay", self.delay)):
            require(bool((values >= 0).all()), f"sensor {what} must be at least 0, got {values.tolist()}")
        require(all(r is None or r > 0 for r in rates), f"sensor rate must be above 0 Hz, got {rates}")
        self.period = np.array([0.0 if r is None else 1.0 / r for r in rates])
        """(k,) seconds between samples of each sensor (0: every step)."""
        self.rng = rng if rng is not None else np.random.default_rng()
        k = len(self.layout.names)
        self._in_flight: list[deque[tuple[float, float, np.ndarray]]] = [deque() for _ in range(k)]
        self._stamps = np.zeros(k)
        self._values = np.zeros(self.layout.size)
        self._next_sample = np.full(k, self.time)
        self._sample(deliver_at_once=True)  # the task was reset when it was built

    @property
    def time(self) -> float:
        """The plant's current time (s): the time a plan made now starts from, later than a delayed reading's."""
        return float(self.task.data.time)

    def plant_sensors(self) -> np.ndarray:
        """(nsensordata,) every sensor of the simulated plant, noiseless and current, for logs and metrics
        (the controller sees only `read_state`)."""
        return self.task.data.sensordata.copy()

    def plant_state(self) -> np.ndarray | None:
        """(nq + nv,) the simulated plant's true state, for logs and metrics (the controller never sees it)."""
        return self.system.plant_state()

    def reset(self) -> None:
        self.system.reset()
        for queue in self._in_flight:
            queue.clear()
        self._next_sample[:] = self.time
        self._sample(deliver_at_once=True)

    def apply(self, action: np.ndarray) -> None:
        self.system.apply(action)

    def step(self) -> None:
        """One plant step, then the samples that fall due are taken and those whose delay has passed arrive."""
        try:
            self.system.step()
        finally:
            self._sample()

    def read_state(self) -> SystemState:
        """The measured sensors last delivered (state None); see the class docstring for the stamps."""
        metadata = self.system.read_state().metadata
        metadata["sensor_times"] = self._stamps.copy()
        return SystemState(None, float(self._stamps.max()), metadata, self._values.copy())

    def _sample(self, deliver_at_once: bool = False) -> None:
        now = self.time
        due = np.flatnonzero(now >= self._next_sample - TIME_TOLERANCE)
        if len(due):
            true = self.system.sensor_values()
            for i in due:
                arrival = now if deliver_at_once else now + self.delay[i]
                self._in_flight[i].append((arrival, now, self._noisy(int(i), true[self.layout.slices[i]])))
                following = self._next_sample[i] + self.period[i]  # on the rate's grid, unless it fell behind
                self._next_sample[i] = following if following > now + TIME_TOLERANCE else now + self.period[i]
        for i, queue in enumerate(self._in_flight):
            while queue and queue[0][0] <= now + TIME_TOLERANCE:
                _, self._stamps[i], self._values[self.layout.slices[i]] = queue.popleft()

    def _noisy(self, i: int, values: np.ndarray) -> np.ndarray:
        std = self.noise[i]
        if not std:
            return values.copy()
        if self.layout.types[i] in QUATERNION_TYPES:
            quat = values / np.linalg.norm(values)
            mujoco.mju_quatIntegrate(quat, self.rng.normal(0.0, std, 3), 1.0)
            return quat
        return values + self.rng.normal(0.0, std, values.shape)


Observe = Literal["state", "sensors"]
"""What the simulated plant serves: its full state, or only the task's measured sensors (rehearsed sensing)."""
OBSERVE_CHOICES = ("state", "sensors")
SENSING_STREAM = 0x73656E7365
"""Second entry of the sensor noise's seed sequence ([seed, SENSING_STREAM]): a stream apart from the plant's."""


@dataclass(frozen=True)
class Sensing:
    """How the app's simulated plant is observed, kept across switches.

    Attributes:
        observe: "state" (the full state) or "sensors" (the measured sensors through `SensedSystem`).
        noise, delay, rate: `SensedSystem`'s per-type settings (std, seconds, Hz), for observe="sensors".
        estimator: registered estimator name; None picks by the first reading (`default_estimator_name`).
        estimator_config: its config; None takes the registered defaults (with the task's overrides).
    """

    observe: Observe = "state"
    noise: PerType = None
    delay: PerType = None
    rate: PerType = None
    estimator: str | None = None
    estimator_config: EstimatorConfig | None = None

    def check(self) -> None:
        """Raise ConfigError for an unknown observe or a config of another estimator; UnknownNameError
        (listing the valid names) for an unregistered estimator."""
        require(
            self.observe in OBSERVE_CHOICES, f"observe must be one of {list(OBSERVE_CHOICES)}, got {self.observe!r}"
        )
        if self.estimator is not None:
            _, config_cls = lookup_estimator(self.estimator)
            if self.estimator_config is not None:
                require(
                    isinstance(self.estimator_config, config_cls),
                    f"estimator_config for {self.estimator!r} must be a {config_cls.__name__}, "
                    f"got {type(self.estimator_config).__name__}",
                )


def observed_plant(task: Task, seed: int | None, sensing: Sensing) -> MujocoSystem | SensedSystem:
    """The simulated plant of `task` (`MujocoSystem.from_task(task, seed)`), behind a SensedSystem serving
    only the measured sensors when `sensing.observe` is "sensors" (its noise drawn from [seed, SENSING_STREAM]).
    ConfigError for a task that declares no measured sensors."""
    plant = MujocoSystem.from_task(task, seed)
    if sensing.observe != "sensors":
        return plant
    rng = np.random.default_rng(None if seed is None else [seed, SENSING_STREAM])
    return SensedSystem(plant, sensing.noise, sensing.delay, sensing.rate, rng)


def choose_estimator(
    task: Task, task_name: str, system: System, sensing: Sensing, reading: SystemState | None = None
) -> tuple[str | None, Estimator | None]:
    """(name, estimator) between `system`'s readings and the plan: `sensing.estimator`, else the task's
    `default_estimator` for a plant whose readings have no full state, else (None, None) (plan from the reading
    as it is).

    `reading` is the plant's latest reading when another thread drives it; None reads it here. ConfigError
    when the estimator cannot fuse the plant's readings.
    """
    name = sensing.estimator
    if reading is None and (name is not None or not isinstance(system, MujocoSystem)):
        reading = check_reading(system, system.read_state())
    if name is None and not isinstance(system, MujocoSystem):  # the simulator reads its full state
        assert reading is not None
        name = default_estimator_name(reading, task)
        name = None if name == "state" else name
    if name is None:
        return None, None
    assert reading is not None
    config_cls = lookup_estimator(name)[1]
    if sensing.estimator is None and not isinstance(sensing.estimator_config, (config_cls, type(None))):
        raise ConfigError(  # a config given for another filter than the task's default
            f"estimator_config is a {type(sensing.estimator_config).__name__}, but {task_name}'s default "
            f"estimator {name!r} takes a {config_cls.__name__}; name the estimator it is for (estimator=...)"
        )
    estimator = make_estimator(name, task, sensing.estimator_config, task_name)
    check_estimator(name, estimator, reading)
    return name, estimator


def check_estimator(name: str, estimator: Estimator, reading: SystemState) -> None:
    """Raise ConfigError unless `estimator` can fuse the plant's `reading` (a filter of sensors on a full-state
    reading, or "state" on a sensors-only one, would fail at every step). Resets it."""
    try:
        estimator.reset(reading)
        estimator.update(reading, reading.time, ControlHistory(estimator.task.nu))
    except ReadingError as err:
        hint = " (observe='sensors' rehearses a robot's sensors in simulation)" if reading.sensors is None else ""
        raise ConfigError(f"the {name!r} estimator cannot run on this plant's readings: {err}{hint}") from None
