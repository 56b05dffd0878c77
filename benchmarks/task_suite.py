"""The task suite at a glance: for each task x optimizer, the update's overhead over the raw rollout
floor and the closed-loop success metrics, as one markdown table per task.

    PYTHONPATH=src python benchmarks/task_suite.py                      # every task x ps, cem, mppi
    PYTHONPATH=src python benchmarks/task_suite.py --tasks acrobot --optimizers ps cem --seeds 2
    PYTHONPATH=src python benchmarks/task_suite.py --markdown results.md

Timing is `python -m judo benchmark`'s: the median control update, and the rollout floor, the median
raw rollout of the same N x T batch on the same pool (interleaved, so both see the same load) times
the controller's max_opt_iters (an update rolls out one batch per iteration); "overhead" is their
ratio. An optimizer that ends its cycle early (stop_cond) can score below 1. Quality is `python -m
judo evaluate`'s: one episode per seed from the task's randomised start, no latency, each metric's
mean ± 95% CI over seeds (the CI is n/a for one seed). Episodes last
`--duration` seconds, or the task's entry in LONGER_EPISODES when that is longer.
"""

import argparse
import sys
from pathlib import Path

import numpy as np
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from judo.cli_shared import check_names, output_console, progress_console
from judo.core.errors import JudoError
from judo.evaluation.evaluate import EvaluateArgs, evaluate
from judo.evaluation.report import summarize_metrics
from judo.evaluation.shared_options import chosen_tasks
from judo.evaluation.stats import Summary
from judo.evaluation.timing import time_pair

LONGER_EPISODES = {
    "leap_cube": 60.0,
    "leap_cube_down": 60.0,
    "fr3_pick": 20.0,
    "double_cartpole": 30.0,
}
"""Seconds per episode for tasks whose metric needs more time than the default: goals per minute, a
full pick and place, and a cart that may drift to the end of its rail only after a while."""


def cell(summary: Summary) -> str:
    """`mean ± ci` to three significant figures, or just the mean when the CI is undefined."""
    if np.isnan(summary.ci95):
        return f"{summary.mean:.3g}"
    return f"{summary.mean:.3g} ± {summary.ci95:.2g}"


def task_rows(
    task: str, optimizers: list[str], args: argparse.Namespace, progress: Progress
) -> list[str]:
    """The markdown table of one task: a header, then one row per optimizer."""
    duration = max(args.duration, LONGER_EPISODES.get(task, 0.0))
    rows = []
    metric_names: list[str] = []
    for optimizer in optimizers:
        progress.update(progress.task_ids[0], description=f"{task} x {optimizer}")
        timing = time_pair(task, optimizer, args.timing_samples)
        episodes = evaluate(
            EvaluateArgs(
                task=task,
                optimizer=optimizer,
                seeds=args.seeds,
                first_seed=args.first_seed,
                duration=duration,
            )
        )
        summaries = summarize_metrics(episodes)
        summaries.pop("mean_reward", None)
        metric_names = metric_names or list(summaries)
        update_ms = float(np.median(timing.update_ms))
        cells = [
            optimizer,
            f"{update_ms:.1f}",
            f"{timing.floor_ms():.1f}",
            f"{timing.overhead_ratio():.2f}x",
        ]
        rows.append(
            "| " + " | ".join(cells + [cell(summaries[name]) for name in metric_names]) + " |"
        )
        progress.advance(progress.task_ids[0])
    header = ["optimizer", "update ms", "rollout floor ms", "overhead", *metric_names]
    seeds = f"{args.seeds} seed{'s' if args.seeds > 1 else ''}"
    if args.first_seed:
        seeds += f" from {args.first_seed}"
    title = f"### {task} ({seeds} x {duration:g} s, no latency)"
    return [title, "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header), *rows, ""]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--tasks", nargs="+", default=[], help="registered task names (default: all)"
    )
    parser.add_argument(
        "--optimizers", nargs="+", default=["ps", "cem", "mppi"], help="registered optimizer names"
    )
    parser.add_argument(
        "--seeds",
        type=int,
        default=3,
        help="episodes per pair, seeds first-seed .. first-seed + seeds - 1",
    )
    parser.add_argument("--first-seed", type=int, default=0, help="the first episode's seed")
    parser.add_argument(
        "--duration", type=float, default=15.0, help="seconds of sim time per episode"
    )
    parser.add_argument(
        "--timing-samples", type=int, default=30, help="timed control updates per pair"
    )
    parser.add_argument(
        "--markdown", type=Path, default=None, help="also write the tables to this file"
    )
    args = parser.parse_args()
    try:
        check_names(args.tasks, args.optimizers)
    except JudoError as err:
        parser.error(str(err))
    tasks = chosen_tasks(tuple(args.tasks))
    lines: list[str] = []
    # tables on stdout; on a terminal the bar shares it and stays below them
    console = output_console()
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    bar_console = console if sys.stdout.isatty() else progress_console()
    with Progress(*columns, console=bar_console, transient=True) as progress:
        progress.add_task("task suite", total=len(tasks) * len(args.optimizers))
        for task in tasks:
            table = task_rows(task, args.optimizers, args, progress)
            console.print("\n".join(table), markup=False, highlight=False, soft_wrap=True)
            lines += table
    if args.markdown is not None:
        args.markdown.write_text("\n".join(lines))
        console.print(f"wrote {args.markdown}")


if __name__ == "__main__":
    main()
