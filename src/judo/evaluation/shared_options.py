"""What `benchmark` and `evaluate` (and through EpisodeArgs, collect) share on the command line
beyond judo.cli_shared: the `--controller.FIELD` overrides and the configs they make, the episode
checks, the chosen tasks and optimizers, and JSON output (the sensing flags:
`judo.evaluation.sensing.SensingFlags`)."""

import json
import math
from pathlib import Path
from typing import Any

from judo.cli_shared import check_names, optional_fields
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
from judo.core.rollouts.factory import check_rollout_backend


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
    """Write `content` to `path` as indented, standard JSON (NaN and infinities become null),
    creating the parent folder; JudoError if that fails."""
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
"""`--controller.FIELD VALUE` options of `benchmark` and `evaluate`: every ControllerConfig field,
None when not given."""


def given_fields(overrides: Any) -> dict[str, Any]:
    """The fields of a `ControllerOverrides` (or any `optional_fields` class) that were given (not
    None), by name; {} for None."""
    return (
        {}
        if overrides is None
        else {name: value for name, value in vars(overrides).items() if value is not None}
    )


def optimizer_config(task: str, optimizer: str, overrides: Any) -> OptimizerConfig:
    """The optimizer's config for the task (its registered defaults) with the given
    `--optimizer-config.*` fields."""
    return with_updates(make_config(lookup_optimizer(optimizer)[1], task), given_fields(overrides))


def task_config(task: str, overrides: Any) -> Config:
    """The task's TaskConfig (its registered defaults) with the given `--task-config.*` fields
    applied."""
    return with_updates(make_config(lookup_task(task)[1], task), given_fields(overrides))


def controller_config(task: str, overrides: Any, optimizer: str | None = None) -> ControllerConfig:
    """The task's ControllerConfig (its registered defaults, and `optimizer`'s own when given) with
    the given `--controller.*` fields applied; ConfigError for a value the config refuses."""
    defaults = make_config(ControllerConfig, task, optimizer)
    return with_updates(defaults, given_fields(overrides))


def latency_label(latency: str, latency_ms: float | None) -> str:
    """How the --latency and --latency-ms flags' latency reads in titles and JSON: "none",
    "measured" or "25 ms"."""
    return f"{latency_ms:g} ms" if latency_ms is not None else latency


def check_episode_args(args: Any) -> None:
    """The checks every command that runs episodes shares (evaluate, collect): registered names, the
    duration, the latency flags, the backend, and the --controller, --optimizer-config and
    --task-config fields against the pair's configs. Raises a JudoError saying which argument is
    wrong."""
    require(
        args.runs_mpc or getattr(args, "policy", None) is not None,
        "give --optimizer NAME (or --policy FILE.onnx to run a policy)",
    )
    check_names([args.task], [args.optimizer] if args.runs_mpc else [])
    require_between("--duration", args.duration, 0, 86_400.0, " s", above=True)
    require(
        args.latency_ms is None or args.latency == "none",
        f"give either --latency {args.latency} or --latency-ms {args.latency_ms}, not both",
    )
    if args.latency_ms is not None:
        require_between("--latency-ms", args.latency_ms, 0, 60_000.0)
    check_rollout_backend(args.backend)
    controller_config(args.task, args.controller, args.optimizer)
    if args.runs_mpc:
        optimizer_config(args.task, args.optimizer, getattr(args, "optimizer_config", None))
    task_config(args.task, getattr(args, "task_config", None))
