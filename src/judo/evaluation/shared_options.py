"""What `benchmark` and `evaluate` (and through EpisodeArgs, collect) share on the command line beyond
judo.cli_shared: the `--controller.FIELD` overrides and the configs they make, the episode checks, the
chosen tasks and optimizers, and JSON output; and `SensingFlags`, how a simulated plant is observed, which the
app's and tune's command lines share too:

    --observe sensors --sensor-noise 0.005 --sensor-rate-hz 100 --sensor-rate-hz framepos=30 \\
        --sensor-delay-ms framepos=40 --estimator ekf

The per-type flags may be repeated, each value NUMBER (every measured sensor) or TYPE=NUMBER (one sensor type,
e.g. framepos); `judo.cli_shared.merge_repeated` gathers the repeats before tyro parses them."""

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Literal

from judo.cli_shared import PER_TYPE_FLAGS, check_names, optional_fields
from judo.core.configuration.config import Config, require, require_between, with_updates
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import (
    get_registered_optimizers,
    get_registered_tasks,
    lookup_optimizer,
    lookup_task,
    make_config,
)
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.rollouts.backend import check_rollout_backend
from judo.core.sensors import DEFAULT_KEY, parse_per_type
from judo.loop.sensing import PerType, Sensing


def all_or(names: tuple[str, ...], registered: dict[str, Any]) -> list[str]:
    """`names`, or every registered name (in registration order) when `names` is empty."""
    return list(names) if names else list(registered)


def chosen_tasks(names: tuple[str, ...]) -> list[str]:
    """The tasks named, or all registered tasks."""
    return all_or(names, get_registered_tasks())


def chosen_optimizers(names: tuple[str, ...]) -> list[str]:
    """The optimizers named, or all registered optimizers."""
    return all_or(names, get_registered_optimizers())


def write_json(path: Path, content: Any) -> None:
    """Write `content` to `path` as indented, standard JSON (NaN and infinities become null), creating
    the parent folder; JudoError if that fails."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(non_finite_to_none(content), indent=2, allow_nan=False) + "\n")
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err


def non_finite_to_none(content: Any) -> Any:
    """`content` with every NaN or infinite float, in nested dicts and lists, replaced by None."""
    if isinstance(content, dict):
        return {key: non_finite_to_none(value) for key, value in content.items()}
    if isinstance(content, (list, tuple)):
        return [non_finite_to_none(value) for value in content]
    if isinstance(content, float) and not math.isfinite(content):
        return None
    return content


ControllerOverrides = optional_fields(ControllerConfig, "ControllerOverrides")
"""`--controller.FIELD VALUE` options of `benchmark` and `evaluate`: every ControllerConfig field, None when not given."""


def given_fields(overrides: Any) -> dict[str, Any]:
    """The fields of a `ControllerOverrides` (or any `optional_fields` class) that were given (not None), by
    name; {} for None."""
    return {} if overrides is None else {name: value for name, value in vars(overrides).items() if value is not None}


def optimizer_config(task: str, optimizer: str, overrides: Any) -> OptimizerConfig:
    """The optimizer's config for the task (its registered defaults) with the given `--optimizer-config.*` fields."""
    return with_updates(make_config(lookup_optimizer(optimizer)[1], task), given_fields(overrides))


def task_config(task: str, overrides: Any) -> Config:
    """The task's TaskConfig (its registered defaults) with the given `--task-config.*` fields applied."""
    return with_updates(make_config(lookup_task(task)[1], task), given_fields(overrides))


def controller_config(task: str, overrides: Any, optimizer: str | None = None) -> ControllerConfig:
    """The task's ControllerConfig (its registered defaults, and `optimizer`'s own when given) with the given
    `--controller.*` fields applied; ConfigError for a value the config refuses."""
    defaults = make_config(ControllerConfig, task, optimizer)
    return with_updates(defaults, given_fields(overrides))


def latency_label(latency: str, latency_ms: float | None) -> str:
    """How the --latency and --latency-ms flags' latency reads in titles and JSON: "none", "measured" or "25 ms"."""
    return f"{latency_ms:g} ms" if latency_ms is not None else latency


def check_episode_args(args: Any) -> None:
    """The checks every command that runs episodes shares (evaluate, collect): registered names, the
    duration, the latency flags, the backend, and the --controller, --optimizer-config and --task-config
    fields against the pair's configs. Raises a JudoError saying which argument is wrong."""
    require(
        args.optimizer is not None or getattr(args, "policy", None) is not None,
        "give --optimizer NAME (or --policy FILE.onnx to run a policy)",
    )
    check_names([args.task], [] if args.optimizer is None else [args.optimizer])
    require_between("--duration", args.duration, 0, 86_400.0, " s", above=True)
    require(
        args.latency_ms is None or args.latency == "none",
        f"give either --latency {args.latency} or --latency-ms {args.latency_ms}, not both",
    )
    if args.latency_ms is not None:
        require_between("--latency-ms", args.latency_ms, 0, 60_000.0)
    check_rollout_backend(args.backend)
    controller_config(args.task, args.controller, args.optimizer)
    if args.optimizer is not None:
        optimizer_config(args.task, args.optimizer, getattr(args, "optimizer_config", None))
    task_config(args.task, getattr(args, "task_config", None))


FLAG_BOUNDS: dict[str, tuple[float, float, str]] = {
    "--sensor-noise": (0, 100, " (a std in the sensor's unit: m, rad, m/s, rad/s, m/s^2)"),
    "--sensor-delay-ms": (0, 10_000, " ms"),
    "--sensor-rate-hz": (0.1, 1_000_000, " Hz"),
}
"""flag -> (lowest, highest, unit) of each of its values: a finite std no sensor exceeds (100 m/s^2 is 10 g), a
delay up to 10 s, a rate of one sample per 10 s up to 1 MHz. Beyond them a value is a typo, not a sensor."""


@dataclasses.dataclass(kw_only=True)
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
