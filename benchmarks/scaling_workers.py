"""How the control update scales with the number of rollout worker threads (1 to the number of
cores).

PYTHONPATH=src python benchmarks/scaling_workers.py [--task cartpole] [--optimizer
mppi] [--num-rollouts 128]
"""

import os
from dataclasses import dataclass

import tyro
from rich.console import Console
from rich.table import Table

from judo.evaluation.timing import time_pair


@dataclass
class Args:
    """What to scale and how often to time it."""

    task: str = "cartpole"
    """Task, by registered name."""
    optimizer: str = "mppi"
    """Optimizer, by registered name."""
    num_rollouts: int = 128
    """Rollouts per update (N); large enough to split across the workers."""
    samples: int = 30
    """Timed updates per worker count, after a warm-up of 10."""
    max_workers: int = os.cpu_count() or 1
    """Largest worker count timed (default: the number of cores)."""


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    table = Table(
        title=f"{args.task} x {args.optimizer}: control update vs rollout workers, "
        f"N={args.num_rollouts}"
    )
    for column in (
        "workers",
        "update median (ms)",
        "rollout floor (ms)",
        "ratio",
        "speed-up vs 1 worker",
    ):
        table.add_column(column, justify="right")
    single = None
    for workers in range(1, args.max_workers + 1):
        row = time_pair(
            args.task,
            args.optimizer,
            args.samples,
            num_rollouts=args.num_rollouts,
            num_workers=workers,
        ).row()
        single = single or row["median_ms"]
        table.add_row(
            str(workers),
            f"{row['median_ms']:.2f}",
            f"{row['floor_ms']:.2f}",
            f"{row['overhead_ratio']:.2f}x",
            f"{single / row['median_ms']:.2f}x",
        )
    Console(width=120).print(table)


if __name__ == "__main__":
    main()
