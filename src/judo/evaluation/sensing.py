"""How a command's simulated plant is observed, for every command that runs one (the app, evaluate,
tune, collect, excite): `Sensing`, the choice kept across switches; `observed_plant`, the plant it
builds (judo's simulator, behind rehearsed sensing, `judo.loop.sensing.SensedSystem`, with
observe="sensors"); `choose_estimator`, the filter between a plant's readings and the plan; and
`SensingFlags`, their command-line flags `--observe`, `--sensor-noise`, `--sensor-delay-ms`,
`--sensor-rate-hz` and `--estimator`:

    --observe sensors --sensor-noise 0.005 --sensor-rate-hz 100 --sensor-rate-hz framepos=30 \\
        --sensor-delay-ms framepos=40 --estimator ekf

The per-type flags may be repeated, each value NUMBER (every measured sensor) or TYPE=NUMBER (one
sensor type, e.g. framepos); `judo.cli_shared.merge_repeated` gathers the repeats before tyro parses
them.
"""

from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.cli_shared import PER_TYPE_FLAGS
from judo.core.configuration.config import require, require_between
from judo.core.configuration.registry import lookup_estimator, make_estimator
from judo.core.errors import ConfigError
from judo.core.estimator import (
    ControlHistory,
    Estimator,
    EstimatorConfig,
    ReadingError,
    default_estimator_name,
)
from judo.core.reading import SystemState
from judo.core.sensors import DEFAULT_KEY, parse_per_type
from judo.core.task import Task
from judo.loop.sensing import PerType, SensedSystem
from judo.loop.system import MujocoSystem, System, check_reading

Observe = Literal["state", "sensors"]
"""What the simulated plant serves: its full state, or only the task's measured sensors (rehearsed
sensing)."""
OBSERVE_CHOICES = ("state", "sensors")
SENSING_STREAM = 0x73656E7365
"""Second entry of the sensor noise's seed sequence ([seed, SENSING_STREAM]): a stream apart from
the plant's."""


@dataclass(frozen=True)
class Sensing:
    """How the app's simulated plant is observed, kept across switches.

    Attributes:
        observe: "state" (the full state) or "sensors" (the measured sensors
            through `SensedSystem`).
        noise, delay, rate: `SensedSystem`'s per-type settings (std, seconds, Hz), for
            observe="sensors".
        estimator: registered estimator name; None picks by the first
            reading (`default_estimator_name`).
        estimator_config: its config; None takes the registered defaults (with the task's
            overrides).
    """

    observe: Observe = "state"
    noise: PerType = None
    delay: PerType = None
    rate: PerType = None
    estimator: str | None = None
    estimator_config: EstimatorConfig | None = None

    def check(self) -> None:
        """Raise ConfigError for an unknown observe or a config of another estimator;
        UnknownNameError (listing the valid names) for an unregistered estimator."""
        require(
            self.observe in OBSERVE_CHOICES,
            f"observe must be one of {list(OBSERVE_CHOICES)}, got {self.observe!r}",
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
    """The simulated plant of `task` (`MujocoSystem.from_task(task, seed)`), behind a SensedSystem
    serving only the measured sensors when `sensing.observe` is "sensors" (its noise drawn from
    [seed, SENSING_STREAM]). ConfigError for a task that declares no measured sensors."""
    plant = MujocoSystem.from_task(task, seed)
    if sensing.observe != "sensors":
        return plant
    rng = np.random.default_rng(None if seed is None else [seed, SENSING_STREAM])
    return SensedSystem(plant, sensing.noise, sensing.delay, sensing.rate, rng)


def choose_estimator(
    task: Task, task_name: str, system: System, sensing: Sensing, reading: SystemState | None = None
) -> tuple[str | None, Estimator | None]:
    """(name, estimator) between `system`'s readings and the plan: `sensing.estimator`, else the
    task's `default_estimator` for a plant whose readings have no full state, else (None, None)
    (plan from the reading as it is).

    `reading` is the plant's latest reading when another thread drives it; None reads it here.
    ConfigError when the estimator cannot fuse the plant's readings.
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
    if sensing.estimator is None and not isinstance(
        sensing.estimator_config, (config_cls, type(None))
    ):
        raise ConfigError(  # a config given for another filter than the task's default
            f"estimator_config is a {type(sensing.estimator_config).__name__}, but "
            f"{task_name}'s default "
            f"estimator {name!r} takes a {config_cls.__name__}; name the estimator it is for "
            "(estimator=...)"
        )
    estimator = make_estimator(name, task, sensing.estimator_config, task_name)
    check_estimator(name, estimator, reading)
    return name, estimator


def check_estimator(name: str, estimator: Estimator, reading: SystemState) -> None:
    """Raise ConfigError unless `estimator` can fuse the plant's `reading` (a filter of sensors on a
    full-state reading, or "state" on a sensors-only one, would fail at every step). Resets it."""
    try:
        estimator.reset(reading)
        estimator.update(reading, reading.time, ControlHistory(estimator.task.nu))
    except ReadingError as err:
        hint = (
            " (observe='sensors' rehearses a robot's sensors in simulation)"
            if reading.sensors is None
            else ""
        )
        raise ConfigError(
            f"the {name!r} estimator cannot run on this plant's readings: {err}{hint}"
        ) from None


FLAG_BOUNDS: dict[str, tuple[float, float, str]] = {
    "--sensor-noise": (0, 100, " (a std in the sensor's unit: m, rad, m/s, rad/s, m/s^2)"),
    "--sensor-delay-ms": (0, 10_000, " ms"),
    "--sensor-rate-hz": (0.1, 1_000_000, " Hz"),
}
"""flag -> (lowest, highest, unit) of each of its values: a finite std no sensor exceeds (100 m/s^2
is 10 g), a delay up to 10 s, a rate of one sample per 10 s up to 1 MHz. Beyond them a value is a
typo, not a sensor."""


@dataclass(kw_only=True)
class SensingFlags:
    """How the simulated plant is observed, and the estimator between its readings and the plan."""

    observe: Literal["state", "sensors"] = "state"
    """What the planner gets from the simulated plant: its full state, or only the task's measured
    sensors (noisy, late, at their rates: rehearsed sensing, fused by --estimator)."""
    sensor_noise: tuple[str, ...] = ()
    """Std of the measured sensors' noise (their units; rad per axis for a quaternion): STD for all,
    or TYPE=STD per sensor type (e.g. framepos=0.002); repeatable. With --observe sensors."""
    sensor_delay_ms: tuple[str, ...] = ()
    """Milliseconds from taking a sample to delivering it: MS, or TYPE=MS (e.g. framepos=40);
    repeatable."""
    sensor_rate_hz: tuple[str, ...] = ()
    """Samples per second: HZ, or TYPE=HZ (e.g. framepos=30); every plant step when not given;
    repeatable."""
    estimator: str | None = None
    """Registered estimator between the readings and the plan (ekf, ukf, state, ...). By default the
    task's own with --observe sensors (ukf for walker and leap_cube, legged for the Unitree robots,
    else ekf), none (the true state as it is) with --observe state."""

    def sensor_settings(self) -> dict[str, PerType]:
        """{"noise": std, "delay": seconds, "rate": Hz} from the per-type flags, each None when not
        given, a float, or {type: value} (ConfigError for a value that is not a number, one outside
        FLAG_BOUNDS, or a setting without --observe sensors)."""
        given = [
            flag
            for flag, values in zip(PER_TYPE_FLAGS, self.per_type_values(), strict=True)
            if values
        ]
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
            per_type = (
                setting
                if isinstance(setting, dict)
                else {DEFAULT_KEY: setting}
                if setting is not None
                else {}
            )
            for key, value in per_type.items():
                require_between(
                    flag if key == DEFAULT_KEY else f"{flag} {key}", value, low, high, unit
                )
        delay = (
            {key: value / 1e3 for key, value in delay_ms.items()}
            if isinstance(delay_ms, dict)
            else delay_ms
        )
        delay = delay / 1e3 if isinstance(delay, float) else delay
        return {"noise": noise, "delay": delay, "rate": rate}

    def per_type_values(self) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
        """The raw values of --sensor-noise, --sensor-delay-ms and --sensor-rate-hz, in that
        order."""
        return self.sensor_noise, self.sensor_delay_ms, self.sensor_rate_hz

    def sensing(self) -> Sensing:
        """The flags as a `Sensing` (checked: ConfigError, or UnknownNameError listing the
        estimators)."""
        sensing = Sensing(self.observe, **self.sensor_settings(), estimator=self.estimator)
        sensing.check()
        return sensing
