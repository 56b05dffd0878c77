"""What `benchmark` and `evaluate` share on the command line: parsing, name checks, consoles, failing cleanly."""

import dataclasses
import json
import math
import sys
import typing
from pathlib import Path
from typing import Annotated, Any, Literal, NoReturn, TypeVar

import numpy as np
import tyro
from rich.console import Console

from judo.core.backend import check_rollout_backend
from judo.core.config import Config, field_types, require, require_between, with_updates
from judo.core.controller import ControllerConfig
from judo.core.errors import JudoError
from judo.core.field_docs import field_docs
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import (
    get_registered_optimizers,
    get_registered_tasks,
    lookup_optimizer,
    lookup_task,
    make_config,
)
from judo.runtime.closed_loop import Latency
from judo.runtime.sensing_flags import merge_repeated

ArgsT = TypeVar("ArgsT")


def fail(message: str) -> NoReturn:
    """Print `error: message` to stderr and exit with status 2, without a traceback."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def parse_args(args_cls: type[ArgsT], argv: list[str] | None, prog: str, description: str) -> ArgsT:
    """Parse `argv` (sys.argv[1:] when None) into `args_cls` with tyro; --help comes from its field docstrings."""
    return tyro.cli(args_cls, args=argv, prog=prog, description=description)


def option_value(argv: list[str], name: str) -> str | None:
    """The value given to `--name` in `argv` ("--name VALUE" or "--name=VALUE"; the last one counts), or None."""
    value = None
    for index, arg in enumerate(argv):
        if arg == f"--{name}" and index + 1 < len(argv):
            value = argv[index + 1]
        elif arg.startswith(f"--{name}="):
            value = arg.split("=", 1)[1]
    return value


def parse_args_with_config_fields(args_cls: type[ArgsT], argv: list[str] | None, prog: str, description: str) -> ArgsT:
    """`parse_args` with two more option groups built for the named pair: `--optimizer-config.FIELD` (every
    field of the --optimizer's config) and `--task-config.FIELD` (every field of the --task's config).

    --config, --task and --optimizer are read from `argv` first (the --config file is loaded, so that its
    tasks and optimizers count); without them, or with an unknown name, the groups are empty and the
    later name check says what is valid.
    """
    from judo.core.task import TaskConfig

    argv = merge_repeated(list(sys.argv[1:] if argv is None else argv))
    try:
        apply_config_file(None if (path := option_value(argv, "config")) is None else Path(path))
    except JudoError as err:
        fail(str(err))
    task, optimizer = option_value(argv, "task"), option_value(argv, "optimizer")
    task_cls = lookup_task(task)[1] if task in get_registered_tasks() else TaskConfig
    optimizer_cls = lookup_optimizer(optimizer)[1] if optimizer in get_registered_optimizers() else OptimizerConfig
    groups = {
        "optimizer_config": (optional_fields(optimizer_cls, "OptimizerOverrides"), "optimizer"),
        "task_config": (optional_fields(task_cls, "TaskOverrides"), "task"),
    }
    specs = [
        (
            name,
            Annotated[
                group, tyro.conf.arg(help=f"Fields of the {kind}'s config ({group.config_cls.__name__}) to change.")
            ],  # type: ignore[attr-defined]
            dataclasses.field(default_factory=group),
        )
        for name, (group, kind) in groups.items()
    ]
    extended = dataclasses.make_dataclass(args_cls.__name__, specs, bases=(args_cls,))
    extended.__doc__ = args_cls.__doc__
    return parse_args(extended, argv, prog, description)


def apply_config_file(path: Path | None) -> None:
    """Read the `--config` TOML file when one is given (registering its classes and applying its overrides),
    the same way the app does; ConfigFileError names the file and the entry that is wrong."""
    if path is not None:
        from judo.core.config_file import load_config

        load_config(path)


def check_names(tasks: tuple[str, ...] | list[str], optimizers: tuple[str, ...] | list[str]) -> None:
    """Raise UnknownNameError (listing the valid names) for a task or optimizer that is not registered."""
    for name in tasks:
        lookup_task(name)
    for name in optimizers:
        lookup_optimizer(name)


def name_listing() -> str:
    """One line naming the registered tasks and optimizers, for --help."""
    return f"Tasks: {', '.join(get_registered_tasks())}. Optimizers: {', '.join(get_registered_optimizers())}."


def all_or(names: tuple[str, ...], registered: dict[str, Any]) -> list[str]:
    """`names`, or every registered name (in registration order) when `names` is empty."""
    return list(names) if names else list(registered)


def chosen_tasks(names: tuple[str, ...]) -> list[str]:
    """The tasks named, or all registered tasks."""
    return all_or(names, get_registered_tasks())


def chosen_optimizers(names: tuple[str, ...]) -> list[str]:
    """The optimizers named, or all registered optimizers."""
    return all_or(names, get_registered_optimizers())


def output_console() -> Console:
    """Console for the results on stdout, 120 columns wide when stdout is not a terminal."""
    return Console(width=None if sys.stdout.isatty() else 120)


def progress_console() -> Console:
    """Console for progress bars on stderr, so stdout holds only the results."""
    return Console(stderr=True)


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


def optional_fields(config_cls: type, name: str) -> type:
    """A dataclass called `name` with every field of `config_cls` as `T | None = None` and the same --help
    text, so that a command line can tell the fields a user gave from those left to the task's defaults."""
    docs, types = field_docs(config_cls), field_types(config_cls)

    def option(name: str) -> Any:
        kind = tuple[float, ...] if types[name] is np.ndarray else types[name]  # an array field takes numbers
        choices = typing.get_args(kind) if typing.get_origin(kind) is Literal else ()
        metavar = "{" + ",".join(map(str, choices)) + "}" if choices else getattr(kind, "__name__", "VALUE").upper()
        metavar = "NUMBER ..." if types[name] is np.ndarray else metavar
        text = " ".join(docs.get(name, "").split())
        return Annotated[
            kind | None, tyro.conf.arg(help=text, metavar=metavar, help_behavior_hint="(default: the task's)")
        ]

    specs = [(f.name, option(f.name), dataclasses.field(default=None)) for f in dataclasses.fields(config_cls)]
    overrides = dataclasses.make_dataclass(name, specs)
    overrides.__doc__ = f"Fields of {config_cls.__name__} to change from the task's defaults."
    overrides.config_cls = config_cls  # type: ignore[attr-defined]
    return overrides


ControllerOverrides = optional_fields(ControllerConfig, "ControllerOverrides")
"""`--controller.FIELD VALUE` options of `benchmark` and `evaluate`: every ControllerConfig field, None when not given."""


def given_fields(overrides: Any) -> dict[str, Any]:
    """The fields of a `ControllerOverrides` (or any `optional_fields` class) that were given (not None), by
    name; {} for None."""
    return {} if overrides is None else {name: value for name, value in vars(overrides).items() if value is not None}


def optimizer_config(task: str, optimizer: str, overrides: Any) -> OptimizerConfig:
    """The optimizer's config for the task (its registered defaults) with the given `--optimizer-config.*` fields."""
    return with_updates(make_config(lookup_optimizer(optimizer)[1], task), given_fields(overrides))  # type: ignore[return-value]


def task_config(task: str, overrides: Any) -> Config:
    """The task's TaskConfig (its registered defaults) with the given `--task-config.*` fields applied."""
    return with_updates(make_config(lookup_task(task)[1], task), given_fields(overrides))  # type: ignore[return-value]


def set_field_overrides(task: str, optimizer: str | None, optimizer_overrides: Any, task_overrides: Any) -> None:
    """Make the given `--optimizer-config.*` and `--task-config.*` fields the pair's defaults in this process,
    as a --config file's [optimizer_config_overrides] and [task_config_overrides] entries do."""
    from judo.core.registry import set_config_overrides

    if optimizer is not None:
        set_config_overrides(task, lookup_optimizer(optimizer)[1], given_fields(optimizer_overrides))
    set_config_overrides(task, lookup_task(task)[1], given_fields(task_overrides))


def controller_config(task: str, overrides: Any, optimizer: str | None = None) -> ControllerConfig:
    """The task's ControllerConfig (its registered defaults, and `optimizer`'s own when given) with the given
    `--controller.*` fields applied; ConfigError for a value the config refuses."""
    defaults = make_config(ControllerConfig, task, optimizer)
    return with_updates(defaults, given_fields(overrides))  # type: ignore[return-value]


def episode_latency(latency: str, latency_ms: float | None) -> Latency:
    """The latency `run_episode` takes for `--latency none|measured` and `--latency-ms MS`: seconds of sim
    time, or "measured"."""
    if latency_ms is not None:
        return latency_ms / 1e3
    return "measured" if latency == "measured" else 0.0


def latency_label(latency: str, latency_ms: float | None) -> str:
    """How those flags' latency reads in titles and JSON: "none", "measured" or "25 ms"."""
    return f"{latency_ms:g} ms" if latency_ms is not None else latency


def seeds_label(first: int, count: int) -> str:
    """How a run's seeds read in titles: "5 seeds" for seeds 0 to 4 (the default), "2 seeds (3-4)" otherwise."""
    if first == 0:
        return f"{count} seeds"
    return f"{count} seeds ({first}-{first + count - 1})" if count > 1 else f"1 seed ({first})"


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
