"""The rehearsed-sensing flags every command that runs a simulated plant shares: the app, evaluate, tune and
collect all take `--observe`, `--sensor-noise`, `--sensor-delay-ms`, `--sensor-rate-hz` and `--estimator`.

    --observe sensors --sensor-noise 0.005 --sensor-rate-hz 100 --sensor-rate-hz framepos=30 \\
        --sensor-delay-ms framepos=40 --estimator ekf

The per-type flags may be repeated, each value NUMBER (every measured sensor) or TYPE=NUMBER (one sensor
type, e.g. framepos); `merge_repeated` gathers the repeats before tyro parses them.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from judo.core.config import require, require_between
from judo.core.sensors import DEFAULT_KEY, parse_per_type
from judo.runtime.sensing import PerType
from judo.runtime.session import Sensing

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
