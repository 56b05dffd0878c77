"""Rehearsed sensing: the simulator seen through a robot's sensors, noisy, late and at their own rates.

    system = SensedSystem(MujocoSystem(task), noise={"default": 0.005, "framequat": 0.017},
                          delay={"framepos": 0.04, "framequat": 0.04}, rate={"default": 100, "framepos": 30})

Each setting is one value for every measured sensor or a mapping {sensor type: value} with an optional
"default" (see `judo.core.sensors.per_sensor`).

Also here, for every command that runs a simulated plant (the app, evaluate, tune and collect): `Sensing`, how
the plant is observed; `observed_plant`, the plant it builds; `choose_estimator`, the filter between its readings
and the plan; and `SensingFlags`, the command-line flags `--observe`, `--sensor-noise`, `--sensor-delay-ms`,
`--sensor-rate-hz` and `--estimator`:

    --observe sensors --sensor-noise 0.005 --sensor-rate-hz 100 --sensor-rate-hz framepos=30 \\
        --sensor-delay-ms framepos=40 --estimator ekf

The per-type flags may be repeated, each value NUMBER (every measured sensor) or TYPE=NUMBER (one sensor
type, e.g. framepos); `merge_repeated` gathers the repeats before tyro parses them.
"""

from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.registry import lookup_estimator, make_estimator
from judo.core.errors import ConfigError
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig, ReadingError, default_estimator_name
from judo.core.sensors import DEFAULT_KEY, QUATERNION_TYPES, parse_per_type, per_sensor
from judo.core.task import Task
from judo.loop.system import MujocoSystem, System, SystemState, check_reading

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


PER_TYPE_FLAGS = ("--sensor-noise", "--sensor-delay-ms", "--sensor-rate-hz")
"""Flags that may be repeated, each value NUMBER or TYPE=NUMBER (e.g. --sensor-rate-hz framepos=30)."""
FLAG_BOUNDS: dict[str, tuple[float, float, str]] = {
    "--sensor-noise": (0, 100, " (a std in the sensor's unit: m, rad, m/s, rad/s, m/s^2)"),
    "--sensor-delay-ms": (0, 10_000, " ms"),
    "--sensor-rate-hz": (0.1, 1_000_000, " Hz"),
}
"""flag -> (lowest, highest, unit) of each of its values: a finite std no sensor exceeds (100 m/s^2 is 10 g), a
delay up to 10 s, a rate of one sample per 10 s up to 1 MHz. Beyond them a value is a typo, not a sensor."""


@dataclass(kw_only=True)
class SensingFlags:
    """How the simulated plant is observed, and the estimator between its readings and the plan."""

    observe: Literal["state", "sensors"] = "state"
    """What the planner gets from the simulated plant: its full state, or only the task's measured sensors
    (noisy, late, at their rates: rehearsed sensing, fused by --estimator)."""
    sensor_noise: tuple[str, ...] = ()
    """Std of the measured sensors' noise (their units; rad per axis for a quaternion): STD for all, or
    TYPE=STD per sensor type (e.g. framepos=0.002); repeatable. With --observe sensors."""
    sensor_delay_ms: tuple[str, ...] = ()
    """Milliseconds from taking a sample to delivering it: MS, or TYPE=MS (e.g. framepos=40); repeatable."""
    sensor_rate_hz: tuple[str, ...] = ()
    """Samples per second: HZ, or TYPE=HZ (e.g. framepos=30); every plant step when not given; repeatable."""
    estimator: str | None = None
    """Registered estimator between the readings and the plan (ekf, ukf, state, ...). By default the task's own
    with --observe sensors (ukf for walker and leap_cube, else ekf), none (the true state as it is) with
    --observe state."""

    def sensor_settings(self) -> dict[str, PerType]:
        """{"noise": std, "delay": seconds, "rate": Hz} from the per-type flags, each None when not given, a
        float, or {type: value} (ConfigError for a value that is not a number, one outside FLAG_BOUNDS, or a
        setting without --observe sensors)."""
        given = [flag for flag, values in zip(PER_TYPE_FLAGS, self.per_type_values(), strict=True) if values]
        require(
            not given or self.observe == "sensors",
            f"{', '.join(given)} set the rehearsed sensors, which run only with --observe sensors",
        )
        noise, delay_ms, rate = (
            parse_per_type(values, flag) if values else None
            for flag, values in zip(PER_TYPE_FLAGS, self.per_type_values(), strict=True)
        )
        for flag, setting in zip(PER_TYPE_FLAGS, (noise, delay_ms, rate), strict=True):
            low, high, unit = FLAG_BOUNDS[flag]
            per_type = setting if isinstance(setting, dict) else {DEFAULT_KEY: setting} if setting is not None else {}
            for key, value in per_type.items():
                require_between(flag if key == DEFAULT_KEY else f"{flag} {key}", value, low, high, unit)
        delay = {key: value / 1e3 for key, value in delay_ms.items()} if isinstance(delay_ms, dict) else delay_ms
        delay = delay / 1e3 if isinstance(delay, float) else delay
        return {"noise": noise, "delay": delay, "rate": rate}

    def per_type_values(self) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
        """The raw values of --sensor-noise, --sensor-delay-ms and --sensor-rate-hz, in that order."""
        return self.sensor_noise, self.sensor_delay_ms, self.sensor_rate_hz

    def sensing(self) -> Sensing:
        """The flags as a `Sensing` (checked: ConfigError, or UnknownNameError listing the estimators)."""
        sensing = Sensing(self.observe, **self.sensor_settings(), estimator=self.estimator)
        sensing.check()
        return sensing


def merge_repeated(argv: list[str], flags: Sequence[str] = PER_TYPE_FLAGS) -> list[str]:
    """`argv` with every repeat of each of `flags` gathered into its first occurrence:
    ["--sensor-rate-hz", "100", "--sensor-rate-hz", "framepos=30"] -> ["--sensor-rate-hz", "100", "framepos=30"]."""
    merged: list[str] = []
    first: dict[str, int] = {}  # flag -> index in `merged` after its values so far
    i = 0
    while i < len(argv):
        arg = argv[i]
        flag, eq, inline = arg.partition("=")
        if flag not in flags:
            merged.append(arg)
            i += 1
            continue
        values = [inline] if eq else []
        i += 1
        while not eq and i < len(argv) and not argv[i].startswith("--"):
            values.append(argv[i])
            i += 1
        if flag in first:
            at = first[flag]
            merged[at:at] = values
            first = {f: (n + len(values) if n >= at and f != flag else n) for f, n in first.items()}
            first[flag] = at + len(values)
        else:
            merged += [flag, *values]
            first[flag] = len(merged)
    return merged
