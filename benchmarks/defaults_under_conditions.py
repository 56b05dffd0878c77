"""Every task's defaults under the conditions a user's machine brings: the check to run before any
TOML change.

For each task x optimizer x condition, runs seeded closed-loop episodes (evaluate's episodes,
through tune's episode runner) and prints each success metric's mean ± 95% CI over seeds. A
condition is a replanning rate and a fixed planning latency (`python -m judo tune --conditions`
syntax); by default the task's check set: its slowest rate `Task.min_control_freq` (20 Hz; 50 Hz for
acrobot and double_cartpole, which diverge too fast for less) and the task's own rate, crossed with
no latency and `Task.check_latency_ms`
(25 ms; 50 ms for leap_cube, leap_cube_down and fr3_pick).

A **collapse** is flagged where a condition loses, against the pair's best condition, more than 0.1
of a fraction metric (a metric whose means all lie in [0, 1], e.g. balanced_fraction) or more
than 25% of a rate
(any other metric, e.g. goals_per_minute). Metrics the task lists in `lower_is_better` (distances,
drops) and mean_reward are printed but not judged. The script exits with status 1 when it flags a
collapse.

Run it before changing a task's TOML (src/judo/tasks/models/<task>.toml), with the candidate
as --config; then, second, regenerate the snapshot of the defaults (`PYTHONPATH=src python
tests/tasks/test_task_defaults.py`):

    PYTHONPATH=src python benchmarks/defaults_under_conditions.py --tasks cartpole --optimizers ps cem mppi \\
        --seeds 5 --duration 10 [--config candidate.toml] [--first-seed 5] [--markdown out.md]
"""  # noqa: E501

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import judo
from judo.core.configuration.registry import get_registered_tasks, lookup_optimizer, lookup_task
from judo.core.errors import JudoError
from judo.evaluation.report import summarize_metrics
from judo.evaluation.stats import Summary
from judo.tuning.conditions import Condition, check_conditions, parse_conditions
from judo.tuning.trial import TrialSpec, run_seeded_episodes

FRACTION_DROP = 0.1
"""A fraction metric collapses when it is more than this below the pair's best condition."""
RATE_DROP = 0.25
"""Any other judged metric collapses when it is more than this share below the pair's best
condition."""


@dataclass
class Collapse:
    """One condition of a task x optimizer that lost too much of a metric against the pair's best
    condition."""

    task: str
    optimizer: str
    metric: str
    condition: str
    value: float
    best_condition: str
    best: float

    def __str__(self) -> str:
        return (
            f"{self.task} x {self.optimizer}: {self.metric} {self.value:.3g} at {self.condition} "
            f"against {self.best:.3g} at {self.best_condition}"
        )


def judged_metrics(task: str, names: list[str]) -> list[str]:
    """The metrics a collapse is judged on: the task's own, better higher (not mean_reward)."""
    lower = lookup_task(task)[0].lower_is_better
    return [name for name in names if name != "mean_reward" and name not in lower]


def collapses(
    task: str, optimizer: str, by_condition: dict[str, dict[str, Summary]]
) -> list[Collapse]:
    """Every (judged metric, condition) of one pair that collapses against the pair's best
    condition."""
    found = []
    names = list(next(iter(by_condition.values())))
    for metric in judged_metrics(task, names):
        means = {label: summaries[metric].mean for label, summaries in by_condition.items()}
        best_label = max(means, key=lambda label: means[label])
        best = means[best_label]
        fraction = all(0.0 <= mean <= 1.0 for mean in means.values())
        for label, mean in means.items():
            lost = (
                best - mean > FRACTION_DROP + 1e-9
                if fraction
                else mean < (1 - RATE_DROP) * best - 1e-9
            )
            if lost:
                found.append(Collapse(task, optimizer, metric, label, mean, best_label, best))
    return found


def measure(
    task: str,
    optimizer: str,
    condition: Condition,
    args: argparse.Namespace,
    config_file: str | None,
) -> dict[str, Summary]:
    """Each metric's mean ± CI over the seeds of one task x optimizer x condition."""
    spec = TrialSpec(
        task,
        optimizer,
        "mean_reward",
        args.seeds,
        args.duration,
        0.0,
        config_file,
        {},
        args.num_workers,
    )
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    return summarize_metrics(run_seeded_episodes(spec, {}, seeds, condition))


def cell(summary: Summary) -> str:
    """ "mean ± ci95" (just the mean for one seed)."""
    return (
        f"{summary.mean:.3g}"
        if math.isnan(summary.ci95)
        else (f"{summary.mean:.3g} ± {summary.ci95:.2g}")
    )


def table_lines(
    task: str, rows: list[tuple[str, str, dict[str, Summary]]], flagged: set[tuple]
) -> list[str]:
    """A markdown table: one row per optimizer x condition, a column per metric (collapses marked
    **!**)."""
    names = list(rows[0][2])
    lines = [
        "| optimizer | condition | " + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for optimizer, label, summaries in rows:
        cells = [
            cell(summaries[name]) + (" **!**" if (optimizer, name, label) in flagged else "")
            for name in names
        ]
        lines.append(f"| {optimizer} | {label} | " + " | ".join(cells) + " |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--tasks", nargs="+", default=None, help="tasks (default: every registered task)"
    )
    parser.add_argument("--optimizers", nargs="+", default=["ps", "cem", "mppi"])
    parser.add_argument(
        "--conditions",
        nargs="+",
        default=(),
        help="as tune's, e.g. control_freq=20,50 latency_ms=0",
    )
    parser.add_argument("--conditions-mode", choices=("crossed", "listed"), default="crossed")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument(
        "--first-seed", type=int, default=0, help="seeds first-seed .. first-seed + seeds - 1"
    )
    parser.add_argument(
        "--duration", type=float, default=15.0, help="seconds of sim time per episode"
    )
    parser.add_argument("--num-workers", type=int, default=1, help="rollout threads per episode")
    parser.add_argument(
        "--config", type=Path, default=None, help="a --config TOML to check (e.g. a candidate)"
    )
    parser.add_argument(
        "--markdown", type=Path, default=None, help="also write the tables to this file"
    )
    args = parser.parse_args()
    config_file = None if args.config is None else str(args.config.resolve())
    try:
        if config_file is not None:
            judo.load_config(config_file)
        tasks = args.tasks or list(get_registered_tasks())
        for name in tasks:
            lookup_task(name)
        for name in args.optimizers:
            lookup_optimizer(name)
        given = parse_conditions(args.conditions, args.conditions_mode)
    except JudoError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    markdown: list[str] = []
    found: list[Collapse] = []
    for task in tasks:
        conditions = given or check_conditions(task)
        rows = []
        pair_collapses = []
        for optimizer in args.optimizers:
            by_condition = {
                c.label: measure(task, optimizer, c, args, config_file) for c in conditions
            }
            rows += [(optimizer, label, summaries) for label, summaries in by_condition.items()]
            pair_collapses += collapses(task, optimizer, by_condition)
        flagged = {(c.optimizer, c.metric, c.condition) for c in pair_collapses}
        title = (
            f"### {task} ({args.seeds} seeds from {args.first_seed} x {args.duration:g} s; **!** "
            "= collapse)"
        )
        lines = [title, "", *table_lines(task, rows, flagged), ""]
        print("\n".join(lines), flush=True)
        markdown += lines
        found += pair_collapses
    summary = ["collapses:", *(f"- {c}" for c in found)] if found else ["no collapse"]
    print("\n".join(summary))
    if args.markdown is not None:
        args.markdown.write_text("\n".join([*markdown, *summary]) + "\n")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
