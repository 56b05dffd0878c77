"""What the commands' command lines share (benchmark, evaluate, tune, collect, replay, distill,
gait-search): parsing with tyro, the `--optimizer-config.FIELD` and `--task-config.FIELD` groups,
the --config file, name checks and listings, the latency flags, the repeated sensing
flags (`merge_repeated`), consoles and failing cleanly. The plant a command line names (`--system`:
`SystemOptions`, `build_system`) is judo.system_choice's.

It sits below the command packages (evaluation, collection, sysid, tuning, learning) and the
runtime.
"""

import dataclasses
import sys
import threading
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, NoReturn, TypeVar

import numpy as np
import tyro
from rich.console import Console
from rich.progress import Progress, ProgressColumn, Task, TaskID, TextColumn

from judo.core.configuration.config import field_types
from judo.core.configuration.field_docs import field_docs
from judo.core.configuration.registry import (
    get_registered_optimizers,
    get_registered_tasks,
    lookup_optimizer,
    lookup_task,
)
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.task import TaskConfig
from judo.loop.timing import Latency

ArgsT = TypeVar("ArgsT")


def fail(message: str) -> NoReturn:
    """Print `error: message` to stderr and exit with status 2, without a traceback."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def parse_args(args_cls: type[ArgsT], argv: list[str] | None, prog: str, description: str) -> ArgsT:
    """Parse `argv` (sys.argv[1:] when None) into `args_cls` with tyro; --help comes from its field
    docstrings."""
    return tyro.cli(args_cls, args=argv, prog=prog, description=description)


def option_value(argv: list[str], name: str) -> str | None:
    """The value given to `--name` in `argv` ("--name VALUE" or "--name=VALUE"; the last one
    counts), or None."""
    value = None
    for index, arg in enumerate(argv):
        if arg == f"--{name}" and index + 1 < len(argv):
            value = argv[index + 1]
        elif arg.startswith(f"--{name}="):
            value = arg.split("=", 1)[1]
    return value


def parse_args_with_config_fields(
    args_cls: type[ArgsT], argv: list[str] | None, prog: str, description: str
) -> ArgsT:
    """`parse_args` with two more option groups built for the named pair: `--optimizer-config.FIELD`
    (every field of the --optimizer's config) and `--task-config.FIELD` (every field of the --task's
    config).

    --config, --task and --optimizer are read from `argv` first (the --config file is loaded, so
    that its tasks and optimizers count); without them, or with an unknown name, the groups are
    empty and the later name check says what is valid.
    """
    argv = merge_repeated(list(sys.argv[1:] if argv is None else argv))
    try:
        apply_config_file(None if (path := option_value(argv, "config")) is None else Path(path))
    except JudoError as err:
        fail(str(err))
    task, optimizer = option_value(argv, "task"), option_value(argv, "optimizer")
    task_cls = lookup_task(task)[1] if task in get_registered_tasks() else TaskConfig
    optimizer_cls = (
        lookup_optimizer(optimizer)[1]
        if optimizer in get_registered_optimizers()
        else OptimizerConfig
    )
    groups = {
        "optimizer_config": (optimizer_cls, "OptimizerOverrides", "optimizer"),
        "task_config": (task_cls, "TaskOverrides", "task"),
    }
    specs = []
    for name, (config_cls, group_name, kind) in groups.items():
        group = optional_fields(config_cls, group_name)
        option = tyro.conf.arg(
            help=f"Fields of the {kind}'s config ({config_cls.__name__}) to change."
        )
        specs.append((name, Annotated[group, option], dataclasses.field(default_factory=group)))
    extended = dataclasses.make_dataclass(args_cls.__name__, specs, bases=(args_cls,))
    extended.__doc__ = args_cls.__doc__
    return parse_args(extended, argv, prog, description)


def apply_config_file(path: Path | None) -> None:
    """Read the `--config` TOML file when one is given (registering its classes and applying its
    overrides), the same way the app does; ConfigFileError names the file and the entry that is
    wrong."""
    if path is not None:
        from judo.core.configuration.config_file import load_config

        load_config(path)


def check_names(
    tasks: tuple[str, ...] | list[str], optimizers: tuple[str, ...] | list[str]
) -> None:
    """Raise UnknownNameError (listing the valid names) for a task or optimizer that is not
    registered."""
    for name in tasks:
        lookup_task(name)
    for name in optimizers:
        lookup_optimizer(name)


def name_listing() -> str:
    """One line naming the registered tasks and optimizers, for --help."""
    return (
        f"Tasks: {', '.join(get_registered_tasks())}. Optimizers: "
        f"{', '.join(get_registered_optimizers())}."
    )


def output_console() -> Console:
    """Console for the results on stdout, 120 columns wide when stdout is not a terminal."""
    return Console(width=None if sys.stdout.isatty() else 120)


def progress_console() -> Console:
    """Console for progress bars on stderr, so stdout holds only the results."""
    return Console(stderr=True)


PROGRESS_PERIOD = 5.0
"""Seconds between the plain progress lines a long command prints where its progress console is no
terminal."""


def progress_display(
    *columns: str | ProgressColumn, console: Console | None = None, transient: bool = True
) -> Progress:
    """The progress display of a long command: rich's `Progress(*columns)` bar on `console`
    (`progress_console()` when None) where it is a terminal; elsewhere (a pipe, a log file, CI) a
    `ProgressLines`, which prints a plain line every PROGRESS_PERIOD seconds. Both are used alike:
    `with progress_display(...) as progress:`, `progress.add_task(...)`, `progress.update(...)`."""
    console = progress_console() if console is None else console
    if console.is_terminal:
        return Progress(*columns, console=console, transient=transient)
    return ProgressLines(*columns, console=console)


class ProgressLines(Progress):
    """A rich `Progress` that draws no bar and instead prints, every `period` seconds while it runs,
    one plain line per visible task: its text columns, then done/total, the time elapsed and the
    time left at the rate so far ("ETA unknown" before anything is done), e.g. `fitting 2
    parameters: 40 residual evaluations | elapsed 0:25` or `collect done 1, failed 0, kept 1, 0.5
    episodes/min | 1/4, elapsed 2:03, ETA 6:09`. Nothing is printed by work shorter than
    `period`."""

    def __init__(
        self, *columns: str | ProgressColumn, console: Console, period: float = PROGRESS_PERIOD
    ) -> None:
        super().__init__(*columns, console=console, disable=True)
        self.period = period
        # each task's completed count when it was added (a resumed run's)
        self._first: dict[TaskID, float] = {}
        self._done = threading.Event()
        self._printer = threading.Thread(
            target=self._print_lines, name="judo-progress-lines", daemon=True
        )

    def add_task(
        self,
        description: str,
        start: bool = True,
        total: float | None = 100.0,
        completed: int = 0,
        visible: bool = True,
        **fields: Any,
    ) -> TaskID:
        """rich's add_task, keeping where the task started for its ETA."""
        task = super().add_task(description, start, total, completed, visible, **fields)
        self._first[task] = completed
        return task

    def start(self) -> None:
        """Start printing lines (no bar is drawn)."""
        super().start()
        if not self._printer.is_alive() and not self._done.is_set():
            self._printer.start()

    def stop(self) -> None:
        """Stop printing lines."""
        self._done.set()
        if self._printer.is_alive() and self._printer is not threading.current_thread():
            self._printer.join()
        super().stop()

    def line(self, task: Task) -> str:
        """The plain line for `task`."""
        text = [
            column(task).plain.strip() for column in self.columns if isinstance(column, TextColumn)
        ]
        elapsed = task.elapsed or 0.0
        figures = [f"elapsed {clock_time(elapsed)}"]
        if task.total is not None:
            rate = (task.completed - self._first.get(task.id, 0)) / elapsed if elapsed > 0 else 0.0
            eta = clock_time((task.total - task.completed) / rate) if rate > 0 else "unknown"
            figures = [f"{task.completed:.4g}/{task.total:.4g}", *figures, f"ETA {eta}"]
        return " ".join(part for part in text if part) + " | " + ", ".join(figures)

    def _print_lines(self) -> None:
        while not self._done.wait(self.period):
            with self._lock:
                lines = [
                    self.line(task) for task in self.tasks if task.visible and not task.finished
                ]
            for line in lines:
                self.console.print(line, markup=False, highlight=False, soft_wrap=True)


def clock_time(seconds: float) -> str:
    """`seconds` as H:MM:SS, or M:SS under an hour."""
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


def optional_fields(config_cls: type, name: str) -> type:
    """A dataclass called `name` with every field of `config_cls` as `T | None = None` and the same
    --help text, so that a command line can tell the fields a user gave from those left to the
    task's defaults. A bool field is a pair of flags, --NAME and --no-NAME, as in the app (whose
    fields have their defaults)."""
    docs, types = field_docs(config_cls), field_types(config_cls)

    def option(name: str) -> Any:
        # an array field takes numbers
        kind = tuple[float, ...] if types[name] is np.ndarray else types[name]
        choices = typing.get_args(kind) if typing.get_origin(kind) is Literal else ()
        metavar = (
            "{" + ",".join(map(str, choices)) + "}"
            if choices
            else getattr(kind, "__name__", "VALUE").upper()
        )
        metavar = "NUMBER ..." if types[name] is np.ndarray else metavar
        text = " ".join(docs.get(name, "").split())
        # --NAME and --no-NAME, the app's flags (tyro's for a bool with a default); None when
        # neither
        if kind is bool:
            hint = "(default: the task's)"
            return Annotated[
                bool | None,
                tyro.conf.DisallowNone,
                tyro.conf.arg(help=text, help_behavior_hint=hint),
            ]
        return Annotated[
            kind | None,
            tyro.conf.arg(help=text, metavar=metavar, help_behavior_hint="(default: the task's)"),
        ]

    specs = [
        (f.name, option(f.name), dataclasses.field(default=None))
        for f in dataclasses.fields(config_cls)
    ]
    overrides = dataclasses.make_dataclass(name, specs, namespace={"config_cls": config_cls})
    overrides.__doc__ = f"Fields of {config_cls.__name__} to change from the task's defaults."
    return overrides


def episode_latency(latency: str, latency_ms: float | None) -> Latency:
    """The latency `run_episode` takes for `--latency none|measured` and `--latency-ms MS`: seconds
    of sim time, or "measured"."""
    if latency_ms is not None:
        return latency_ms / 1e3
    return "measured" if latency == "measured" else 0.0


def optional_pyplot() -> Any:
    """matplotlib.pyplot on its file-only Agg backend, or None when matplotlib (the `plot` extra) is
    missing: the commands' PNG figures are written only where it is installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt


def seeds_label(first: int, count: int) -> str:
    """How a run's seeds read in titles: "5 seeds" for seeds 0 to 4 (the default), "2 seeds (3-4)"
    otherwise."""
    if first == 0:
        return f"{count} seeds"
    return f"{count} seeds ({first}-{first + count - 1})" if count > 1 else f"1 seed ({first})"


PER_TYPE_FLAGS = ("--sensor-noise", "--sensor-delay-ms", "--sensor-rate-hz")
"""Flags that may be repeated, each value NUMBER or TYPE=NUMBER (e.g. --sensor-rate-hz
framepos=30)."""


def merge_repeated(argv: list[str], flags: Sequence[str] = PER_TYPE_FLAGS) -> list[str]:
    """`argv` with every repeat of each of `flags` gathered into its first occurrence:
    ["--sensor-rate-hz", "100", "--sensor-rate-hz", "framepos=30"] -> ["--sensor-rate-hz", "100",
    "framepos=30"]."""
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
