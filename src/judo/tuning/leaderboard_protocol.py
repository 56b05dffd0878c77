"""A leaderboard's protocol: what is held the same for every optimizer on one task, read from a TOML
file.

One file per task, `<task>.toml`: the shipped ones in judo/tuning/protocols/, a user's in the folder
given by `leaderboard --protocols DIR` (looked at first). Every key:

    metric = "upright_fraction"   # the evaluate metric compared (the task's metrics, or mean_reward)
    direction = "maximize"        # its sign: maximize or minimize (default: the task's lower_is_better)
    control_freq = 20.0           # replanning rate, Hz
    latency_ms = 0.0              # fixed planning latency, ms of sim time
    horizon = 1.5                 # planning horizon, s
    spline_order = "cubic"        # zero, linear or cubic (default: the task's)
    num_nodes = 4                 # spline knots over the horizon
    num_rollouts = 32             # N, rollouts per iteration
    duration = 10.0               # episode length, s of sim time
    tuning_seeds = 2              # episodes per trial, seeds tuning_first_seed, tuning_first_seed + 1, ...
    tuning_first_seed = 1000      # the validation seeds (0 to --seeds - 1) never overlap them

Only `metric` is required; a missing setting takes the task's default (what `python -m judo --task
T` runs).
"""  # noqa: E501

import hashlib
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, get_args

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from judo.core.commandline.boundary import MAX_EPISODE, MAX_SEED
from judo.core.configuration.config import require, require_between
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import lookup_task, make_config
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.spline import MIN_KNOTS, SplineOrder
from judo.tuning.conditions import MAX_LATENCY_MS
from judo.tuning.objective import Direction, metric_direction

SHIPPED = Path(__file__).resolve().parent / "protocols"
"""The folder of the built-in tasks' protocol files."""
MAX_TUNING_SEEDS = 1000
"""Most episodes per trial a protocol may ask for."""


class ProtocolError(JudoError):
    """A protocol file that is missing, unreadable, or has an unknown key or a value out of
    range."""


@dataclass(frozen=True)
class Protocol:
    """What every optimizer of a leaderboard shares on one task.

    Attributes:
        task: the registered task name.
        metric, direction: the evaluate metric compared and whether higher or lower is better.
        control_freq: replanning rate in Hz; latency_ms: fixed planning latency in ms of sim time.
        horizon: seconds; spline_order, num_nodes: the control spline; num_rollouts: N.
        duration: seconds of sim time per episode.
        tuning_seeds, tuning_first_seed: the seeds each trial runs (validation runs 0
            to --seeds - 1).
        path: the file it was read from.
    """

    task: str
    metric: str
    direction: Direction
    control_freq: float
    latency_ms: float
    horizon: float
    spline_order: SplineOrder
    num_nodes: int
    num_rollouts: int
    duration: float
    tuning_seeds: int
    tuning_first_seed: int
    path: str

    def fixed(self) -> dict[str, Any]:
        """The settings pinned for every trial of every optimizer, {`kind.field`: value} (the rate
        and latency are the trials' condition instead)."""
        return {
            "controller.horizon": self.horizon,
            "controller.spline_order": self.spline_order,
            "optimizer.num_nodes": self.num_nodes,
            "optimizer.num_rollouts": self.num_rollouts,
        }

    def digest(self) -> str:
        """8 hex digits that change with any setting (not the file's path): part of each study's
        name, so that an edited protocol starts new studies instead of resuming ones scored
        otherwise."""
        values = {key: value for key, value in asdict(self).items() if key != "path"}
        return hashlib.sha256(repr(sorted(values.items())).encode()).hexdigest()[:8]

    def line(self) -> str:
        """E.g. "upright_fraction (maximize), 20 Hz, 0 ms, horizon 1.5 s, cubic 4 knots, N 32, 10 s
        episodes"."""
        return (
            f"{self.metric} ({self.direction}), {self.control_freq:g} Hz, latency "
            f"{self.latency_ms:g} ms, horizon "
            f"{self.horizon:g} s, {self.spline_order} spline of {self.num_nodes} knots, N "
            f"{self.num_rollouts}, "
            f"{self.duration:g} s episodes, tuning seeds {self.tuning_first_seed} to "
            f"{self.tuning_first_seed + self.tuning_seeds - 1}"
        )


KEYS = (
    "metric",
    "direction",
    "control_freq",
    "latency_ms",
    "horizon",
    "spline_order",
    "num_nodes",
    "num_rollouts",
    "duration",
    "tuning_seeds",
    "tuning_first_seed",
)


def protocol_path(task: str, folder: Path | None) -> Path:
    """The protocol file of `task`: `folder/<task>.toml` when it exists, else the shipped one;
    ProtocolError, naming the tasks that have one, when neither does."""
    for place in ([folder] if folder is not None else []) + [SHIPPED]:
        if (place / f"{task}.toml").is_file():
            return place / f"{task}.toml"
    have = sorted(
        {p.stem for place in filter(None, [folder, SHIPPED]) for p in place.glob("*.toml")}
    )
    where = f"{folder} or {SHIPPED}" if folder is not None else str(SHIPPED)
    raise ProtocolError(
        f"task {task!r} has no protocol file {task}.toml in {where}; write one "
        "(docs/optimizers.md) and pass its "
        f"folder as --protocols DIR; tasks with one: {', '.join(have)}"
    )


def number(
    path: Path, table: dict[str, Any], key: str, default: float, integer: bool = False
) -> Any:
    """`table[key]` (or `default`) as a finite number, an int where `integer`; ProtocolError
    otherwise."""
    value = table.get(key, default)
    ok = (
        isinstance(value, int)
        if integer
        else isinstance(value, (int, float)) and math.isfinite(value)
    )
    if isinstance(value, bool) or not ok:
        kind = "an integer" if integer else "a finite number"
        raise ProtocolError(f"{path}: {key} must be {kind}, got {value!r}")
    return int(value) if integer else float(value)


def load_protocol(task: str, folder: Path | None = None) -> Protocol:
    """The protocol of `task` (see the module docstring), checked: ProtocolError naming the file and
    the key."""
    lookup_task(task)  # UnknownNameError listing the tasks first
    path = protocol_path(task, folder)
    try:
        table = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ProtocolError(f"{path}: cannot be read as TOML: {err}") from None
    unknown = sorted(set(table) - set(KEYS))
    if unknown:
        raise ProtocolError(
            f"{path}: unknown key {unknown[0]!r}; valid keys are: {', '.join(KEYS)}"
        )
    metric = table.get("metric")
    if not isinstance(metric, str) or not metric:
        raise ProtocolError(
            f"{path}: metric must name one of the task's evaluate metrics, e.g. metric = "
            '"mean_reward"'
        )
    direction = table.get("direction", metric_direction(task, metric))
    if direction not in get_args(Direction):
        raise ProtocolError(f"{path}: direction must be maximize or minimize, got {direction!r}")
    controller = make_config(ControllerConfig, task)
    optimizer = make_config(OptimizerConfig, task)
    spline_order = table.get("spline_order", controller.spline_order)
    if spline_order not in MIN_KNOTS:
        raise ProtocolError(
            f"{path}: spline_order must be one of {', '.join(MIN_KNOTS)}, got {spline_order!r}"
        )
    protocol = Protocol(
        task=task,
        metric=metric,
        direction=direction,
        control_freq=number(path, table, "control_freq", controller.control_freq),
        latency_ms=number(path, table, "latency_ms", 0.0),
        horizon=number(path, table, "horizon", controller.horizon),
        spline_order=spline_order,
        num_nodes=number(path, table, "num_nodes", optimizer.num_nodes, integer=True),
        num_rollouts=number(path, table, "num_rollouts", optimizer.num_rollouts, integer=True),
        duration=number(path, table, "duration", 10.0),
        tuning_seeds=number(path, table, "tuning_seeds", 2, integer=True),
        tuning_first_seed=number(path, table, "tuning_first_seed", 1000, integer=True),
        path=str(path),
    )
    try:
        check_ranges(protocol)
    except JudoError as err:
        raise ProtocolError(f"{path}: {err}") from None
    return protocol


def check_ranges(protocol: Protocol) -> None:
    """ConfigError for a protocol value out of range (the controller's own checks for its
    settings)."""
    require_between("duration", protocol.duration, 0, MAX_EPISODE, " s", above=True)
    require_between("latency_ms", protocol.latency_ms, 0, MAX_LATENCY_MS, " ms")
    require_between("tuning_seeds", protocol.tuning_seeds, 1, MAX_TUNING_SEEDS)
    require_between(
        "tuning_first_seed", protocol.tuning_first_seed, 0, MAX_SEED - protocol.tuning_seeds + 1
    )
    ControllerConfig(
        horizon=protocol.horizon,
        control_freq=protocol.control_freq,
        spline_order=protocol.spline_order,
    ).validate()
    OptimizerConfig(num_nodes=protocol.num_nodes, num_rollouts=protocol.num_rollouts).validate()
    needed = MIN_KNOTS[protocol.spline_order]
    require(
        protocol.num_nodes >= needed,
        f"a {protocol.spline_order} spline needs at least {needed} knots, got num_nodes = "
        f"{protocol.num_nodes}",
    )
