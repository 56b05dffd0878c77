"""Median control-update time of every task x optimizer against its floor: the raw rollouts of the
same work.

All pairs at the same sizes (N = 32 rollouts, 4 knots, 1 s horizon) so rows compare; the other
settings are each task's defaults. The fixed cost is what an update costs beyond its physics: the
median update minus the floor, in microseconds (and the same of the minima, steadier on a busy
machine). Run from the repository root:

    PYTHONPATH=src python benchmarks/control_update.py [--samples 100] [--num-workers N]

A small update, the size of judo-rai's cart-pole (N = 32, T = 25), on the calling thread's CPU time:

    PYTHONPATH=src python benchmarks/control_update.py --tasks cartpole --optimizers mppi --horizon 0.25 \\
        --num-workers 1 --cpu-time --samples 1000

Every task at its own defaults, as the targets for own models read them:

    PYTHONPATH=src python benchmarks/control_update.py --task-defaults --optimizers mppi --num-workers 1 --cpu-time

It uses only what judo.evaluation.timing has had since the closed loop became a library, so an older
checkout's judo can be timed by the same script: PYTHONPATH=<that checkout>/src.
"""  # noqa: E501

import time
from dataclasses import dataclass

import numpy as np
import tyro
from rich.console import Console
from rich.table import Table

from judo import get_registered_optimizers, get_registered_tasks
from judo.evaluation.timing import benchmark_controller, time_control_update


@dataclass
class Args:
    """Sizes and repetitions of the control-update benchmark."""

    samples: int = 100
    """Timed updates per task x optimizer pair, after a warm-up of 10."""
    num_rollouts: int = 32
    """Rollouts per update (N)."""
    num_nodes: int = 4
    """Spline knots per plan."""
    horizon: float = 1.0
    """Planning horizon in seconds (T = horizon / timestep steps)."""
    num_workers: int | None = None
    """Rollout worker threads (default: one per core)."""
    tasks: tuple[str, ...] = ()
    """Tasks to time (default: every registered one)."""
    optimizers: tuple[str, ...] = ()
    """Optimizers to time (default: every registered one)."""
    task_defaults: bool = False
    """Each task's own N, knots and horizon (its defaults), instead of --num-rollouts, --num-nodes
    and --horizon."""
    cpu_time: bool = False
    """Time the calling thread's CPU time instead of wall time (needs --num-workers 1, so that every
    rollout runs on the timed thread; far steadier on a busy machine)."""


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    if args.cpu_time and args.num_workers != 1:
        raise SystemExit(
            "--cpu-time needs --num-workers 1, so that every rollout runs on the timed thread"
        )
    tasks = args.tasks or tuple(get_registered_tasks())
    optimizers = args.optimizers or tuple(get_registered_optimizers())
    for name, known in (
        ("task", get_registered_tasks()),
        ("optimizer", get_registered_optimizers()),
    ):
        unknown = [n for n in (tasks if name == "task" else optimizers) if n not in known]
        if unknown:
            raise SystemExit(f"unknown {name} {unknown[0]!r}; expected one of {', '.join(known)}")
    clock = time.thread_time if args.cpu_time else time.perf_counter
    sized = (
        "each task's defaults"
        if args.task_defaults
        else f"N={args.num_rollouts}, {args.num_nodes} knots, {args.horizon:g} s"
    )
    table = Table(
        title=f"control update vs rollout floor, {sized}, "
        + ("thread CPU time" if args.cpu_time else "wall time")
    )
    columns = (
        "task",
        "optimizer",
        "N x T",
        "workers",
        "update median (ms)",
        "rollout floor (ms)",
        "ratio",
    )
    for column in (*columns, "fixed cost (us)", "ratio of minima", "fixed cost of minima (us)"):
        table.add_column(column, justify="left" if column in ("task", "optimizer") else "right")
    for task in tasks:
        for optimizer in optimizers:
            sizes = {
                "num_rollouts": args.num_rollouts,
                "num_nodes": args.num_nodes,
                "horizon": args.horizon,
            }
            sizes = {} if args.task_defaults else sizes
            with benchmark_controller(
                task, optimizer, num_workers=args.num_workers, **sizes
            ) as controller:
                update_ms, raw_ms = time_control_update(controller, args.samples, clock=clock)
                iters, shape = controller.config.max_opt_iters, controller.batch_controls.shape
                workers = controller.backend.num_workers
            # one batch per iteration
            median, floor = float(np.median(update_ms)), iters * float(np.median(raw_ms))
            least, least_floor = float(np.min(update_ms)), iters * float(np.min(raw_ms))
            table.add_row(
                task,
                optimizer,
                f"{shape[0]} x {shape[1]}",
                str(workers),
                f"{median:.3f}",
                f"{floor:.3f}",
                f"{median / floor:.3f}x",
                f"{1e3 * (median - floor):.0f}",
                f"{least / least_floor:.3f}x",
                f"{1e3 * (least - least_floor):.0f}",
            )
    Console(width=160).print(table)


if __name__ == "__main__":
    main()
