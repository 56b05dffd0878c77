"""Median control-update time of every task x optimizer against its floor: the raw rollouts of the same work.

All pairs at the same sizes (N = 32 rollouts, 4 knots, 1 s horizon) so rows compare; the other
settings are each task's defaults. Run from the repository root:

    PYTHONPATH=src python benchmarks/control_update.py [--samples 100] [--num-workers N]
"""

from dataclasses import dataclass

import tyro
from rich.console import Console
from rich.table import Table

from judo import get_registered_optimizers, get_registered_tasks
from judo.evaluation.timing import time_pair


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


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    table = Table(
        title=f"control update vs rollout floor, N={args.num_rollouts}, {args.num_nodes} knots, {args.horizon:g} s"
    )
    for column in ("task", "optimizer", "N x T", "workers", "update median (ms)", "rollout floor (ms)", "ratio"):
        table.add_column(column, justify="left" if column in ("task", "optimizer") else "right")
    for task in get_registered_tasks():
        for optimizer in get_registered_optimizers():
            timing = time_pair(
                task,
                optimizer,
                args.samples,
                num_rollouts=args.num_rollouts,
                num_nodes=args.num_nodes,
                horizon=args.horizon,
                num_workers=args.num_workers,
            )
            row = timing.row()
            table.add_row(
                task,
                optimizer,
                f"{row['num_rollouts']} x {row['T']}",
                str(row["num_workers"]),
                f"{row['median_ms']:.2f}",
                f"{row['floor_ms']:.2f}",
                f"{row['overhead_ratio']:.2f}x",
            )
    Console(width=120).print(table)


if __name__ == "__main__":
    main()
