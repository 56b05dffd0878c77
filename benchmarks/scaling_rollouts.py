"""How the control update scales with the number of rollouts N (16 to 512), next to the raw rollout
floor.

PYTHONPATH=src python benchmarks/scaling_rollouts.py [--task cartpole] [--optimizer
mppi] [--samples 30]
"""

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
    num_rollouts: tuple[int, ...] = (16, 32, 64, 128, 256, 512)
    """The N values to time."""
    samples: int = 30
    """Timed updates per N, after a warm-up of 10."""
    num_workers: int | None = None
    """Rollout worker threads (default: one per core)."""


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    table = Table(title=f"{args.task} x {args.optimizer}: control update vs number of rollouts")
    for column in (
        "N x T",
        "update median (ms)",
        "rollout floor (ms)",
        "ratio",
        "update per rollout step (us)",
    ):
        table.add_column(column, justify="right")
    for num_rollouts in args.num_rollouts:
        row = time_pair(
            args.task,
            args.optimizer,
            args.samples,
            num_rollouts=num_rollouts,
            num_workers=args.num_workers,
        ).row()
        table.add_row(
            f"{row['num_rollouts']} x {row['T']}",
            f"{row['median_ms']:.2f}",
            f"{row['floor_ms']:.2f}",
            f"{row['overhead_ratio']:.2f}x",
            f"{1e3 * row['median_ms'] / (row['num_rollouts'] * row['T']):.2f}",
        )
    Console(width=120).print(table)


if __name__ == "__main__":
    main()
