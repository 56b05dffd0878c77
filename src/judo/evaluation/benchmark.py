"""`python -m judo benchmark`: time the control update of every task x optimizer pair against raw
rollouts."""

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np
import tyro
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeRemainingColumn
from rich.table import Table

from judo.cli_shared import (
    apply_config_file,
    check_names,
    fail,
    name_listing,
    output_console,
    parse_args,
    progress_display,
)
from judo.core.commandline.boundary import MAX_SAMPLES, MAX_WORKERS, check_count, check_output_file
from judo.core.configuration.config import require
from judo.core.errors import JudoError
from judo.core.rollouts.backend import RolloutBackendName
from judo.core.rollouts.factory import check_rollout_backend
from judo.evaluation.shared_options import (
    ControllerOverrides,
    chosen_optimizers,
    chosen_tasks,
    controller_config,
    given_fields,
    write_json,
)
from judo.evaluation.timing import UpdateTiming, time_pair

DESCRIPTION = (
    "Time the control update of each task x optimizer pair with the task's default settings, "
    "after a warm-up, "
    "next to the raw rollout of the same N x R x T steps (R: "
    "--controller.num-randomizations, 1 by default) on the same rollout pool (the floor) and "
    "their ratio."
)


@dataclass
class BenchmarkArgs:
    """Arguments of `python -m judo benchmark`."""

    tasks: Annotated[
        tuple[str, ...] | None,
        tyro.conf.arg(metavar="NAME [NAME ...]", help_behavior_hint="(default: all)"),
    ] = None
    """Tasks to time, by registered name."""
    optimizers: Annotated[
        tuple[str, ...] | None,
        tyro.conf.arg(metavar="NAME [NAME ...]", help_behavior_hint="(default: all)"),
    ] = None
    """Optimizers to time, by registered name."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file, as for the app, that registers custom tasks and optimizers and sets per-task
    overrides (docs/configuration.md); read before anything else."""
    samples: int = 100
    """Timed control updates per task x optimizer pair."""
    warmup: int = 10
    """Untimed updates (and raw rollouts) before timing starts."""
    num_workers: Annotated[
        int | None, tyro.conf.arg(metavar="INT", help_behavior_hint="(default: one per core)")
    ] = None
    """Rollout worker threads (cpu backend)."""
    backend: RolloutBackendName = "cpu"
    """Rollout backend: cpu (threads) or warp (MuJoCo Warp; needs pip install -e ".[warp]")."""
    cpu_time: bool = False
    """Time the calling thread's CPU time instead of wall time: far steadier on a busy machine.
    Needs --num-workers 1, so that every rollout runs on the timed thread."""
    json: Annotated[Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")] = (
        None
    )
    """Also write one row per pair to this JSON file."""
    controller: ControllerOverrides = field(default_factory=ControllerOverrides)  # pyright: ignore[reportInvalidTypeForm]
    """Controller settings to change from each task's defaults, e.g. --controller.num-randomizations
    4."""

    def validate(self) -> None:
        """Raise a JudoError for an argument out of range or a name that is not registered."""
        for flag, names in (("--tasks", self.tasks), ("--optimizers", self.optimizers)):
            require(
                names != (), f"{flag} needs at least one name; leave {flag} out for all of them"
            )
        require(self.samples >= 1, f"--samples must be at least 1, got {self.samples}")
        require(self.warmup >= 0, f"--warmup must be at least 0, got {self.warmup}")
        require(
            self.num_workers is None or self.num_workers >= 1,
            f"--num-workers must be at least 1, got {self.num_workers}",
        )
        workers = (
            "no --num-workers (one per core)"
            if self.num_workers is None
            else (f"--num-workers {self.num_workers}")
        )
        require(
            not self.cpu_time or self.num_workers == 1,
            "--cpu-time needs --num-workers 1, so that every rollout runs on the timed "
            f"thread; got {workers}",
        )
        check_names(self.tasks or (), self.optimizers or ())
        check_rollout_backend(self.backend)
        for task in chosen_tasks(self.tasks or ()):
            controller_config(task, self.controller)


def timing_table(task: str, timings: list[UpdateTiming], clock: str = "ms") -> Table:
    """One row per optimizer: update-time statistics (ms, of wall time or of the `clock` the title
    names), the raw rollout, the floor (raw rollout x iterations) and the overhead ratio (median
    update / floor)."""
    backend = timings[0].backend
    on = (
        f"{timings[0].num_workers} rollout workers"
        if backend == "cpu"
        else (f"the {backend} backend")
    )
    table = Table(title=f"{task}: control update time ({clock}), {on}")
    table.add_column("optimizer")
    table.add_column("N x R x T", justify="right")
    table.add_column("mean ± std", justify="right")
    table.add_column("median (IQR)", justify="right")
    table.add_column("min / max", justify="right")
    table.add_column("raw rollout", justify="right")
    table.add_column("iters", justify="right")
    table.add_column("floor", justify="right")
    table.add_column("overhead", justify="right")
    for timing in timings:
        ms = timing.update_ms
        q25, q75 = np.percentile(ms, [25, 75])
        table.add_row(
            timing.optimizer,
            f"{timing.num_rollouts} x {timing.num_randomizations} x {timing.num_steps}",
            f"{ms.mean():.2f} ± {ms.std():.2f}",
            f"{np.median(ms):.2f} ({q25:.2f}-{q75:.2f})",
            f"{ms.min():.2f} / {ms.max():.2f}",
            f"{np.median(timing.raw_rollout_ms):.2f}",
            str(timing.max_opt_iters),
            f"{timing.floor_ms():.2f}",
            f"{timing.overhead_ratio():.2f}x",
        )
    return table


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark on `argv` (sys.argv[1:] when None); returns 0, exits with status 2 on bad
    arguments."""
    args = parse_args(
        BenchmarkArgs, argv, "python -m judo benchmark", DESCRIPTION + " " + name_listing()
    )
    try:
        check_count("--num-workers", args.num_workers, MAX_WORKERS)
        check_count("--samples", args.samples, MAX_SAMPLES)
        check_count("--warmup", args.warmup, MAX_SAMPLES, low=0)
        check_output_file("--json", args.json)
        apply_config_file(args.config)
        args.validate()
        tasks, optimizers = chosen_tasks(args.tasks or ()), chosen_optimizers(args.optimizers or ())
        results: dict[str, list[UpdateTiming]] = {task: [] for task in tasks}
        columns = (
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeRemainingColumn(),
        )
        with progress_display(*columns) as progress:
            bar = progress.add_task("benchmark", total=len(tasks) * len(optimizers) * args.samples)
            for task in tasks:
                for optimizer in optimizers:
                    progress.update(bar, description=f"{task} x {optimizer}")
                    timing = time_pair(
                        task,
                        optimizer,
                        args.samples,
                        warmup=args.warmup,
                        num_workers=args.num_workers,
                        backend=args.backend,
                        on_sample=lambda: progress.advance(bar),
                        controller_updates=given_fields(args.controller),
                        clock=time.thread_time if args.cpu_time else time.perf_counter,
                    )
                    results[task].append(timing)
        console = output_console()
        for task in tasks:
            console.print(
                timing_table(
                    task, results[task], "ms of thread CPU time" if args.cpu_time else "ms"
                )
            )
        if args.json is not None:
            write_json(args.json, [timing.row() for task in tasks for timing in results[task]])
            console.print(f"wrote {args.json}")
    except JudoError as err:
        fail(str(err))
    return 0
