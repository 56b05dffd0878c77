"""The outputs of a leaderboard: the table (rich, markdown), the CSV, and the plot of every entry's
interval.

An entry is a row of the table: each optimizer tuned at the tasks' protocols, and the shipped
default (the app's optimizer with every setting as shipped). A cell is an entry's score on one task:
its metric's mean over the validation seeds with the 95% confidence interval (evaluate's
`summarize`), the task's winner in bold.
"""

import csv
import json
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
from rich.table import Table
from rich.text import Text

from judo.cli_shared import clock_time, optional_pyplot
from judo.core.errors import JudoError
from judo.evaluation.shared_options import write_json
from judo.evaluation.stats import Summary, shown_interval, summarize
from judo.tuning.leaderboard_protocol import Protocol

SHIPPED_ENTRY = "shipped default"
"""The entry's name of the shipped default, e.g. "shipped default (mppi)" with its optimizer."""


@dataclass
class Cell:
    """One entry's result on one task.

    Attributes:
        task, entry: the task and the row's name (an optimizer, or "shipped default (mppi)").
        optimizer: the optimizer that ran.
        scores: (S,) the metric of each validation seed, in seed order; empty until validated or
            when failed.
        failure: why tuning or validation failed, or None.
        tuned_value: the best trial's value on the tuning seeds (None for the shipped default).
        defaults_value: the trial that ran the optimizer's defaults at the protocol, on the tuning
            seeds.
        best_trial: that best trial's number; trials, failed_trials: the study's completed and
            failed trials.
        plan_ms: median control update over the validation episodes, in milliseconds.
        params: the best trial's settings ({`kind.field`: value}); config: the TOML file written for
            them.
    """

    task: str
    entry: str
    optimizer: str
    scores: list[float] = field(default_factory=list)
    failure: str | None = None
    tuned_value: float | None = None
    defaults_value: float | None = None
    best_trial: int | None = None
    trials: int = 0
    failed_trials: int = 0
    plan_ms: float | None = None
    params: dict[str, Any] = field(default_factory=dict)
    config: str | None = None

    @property
    def summary(self) -> Summary | None:
        """The scores' mean and 95% interval, or None without scores."""
        return summarize(np.array(self.scores)) if self.scores and self.failure is None else None

    def text(self) -> str:
        """The cell as the table shows it: "0.93 ± 0.04", or why there is none."""
        summary = self.summary
        if summary is not None:
            return shown_interval(summary)
        return "failed" if self.failure is not None else "not validated"


def winners(cells: list[Cell], protocol: Protocol) -> set[str]:
    """The entries of one task's `cells` with the best mean (ties, to rounding, all win); none
    without a score."""
    means = {cell.entry: summary.mean for cell in cells if (summary := cell.summary) is not None}
    finite = {entry: mean for entry, mean in means.items() if math.isfinite(mean)}
    if not finite:
        return set()
    best = max(finite.values()) if protocol.direction == "maximize" else min(finite.values())
    return {
        entry
        for entry, mean in finite.items()
        if math.isclose(mean, best, rel_tol=1e-9, abs_tol=1e-12)
    }


def entries_of(cells: list[Cell]) -> list[str]:
    """The rows in order: the optimizers as given, then the shipped default."""
    names = list(dict.fromkeys(cell.entry for cell in cells))
    return [name for name in names if not name.startswith(SHIPPED_ENTRY)] + [
        name for name in names if name.startswith(SHIPPED_ENTRY)
    ]


def column_title(protocol: Protocol) -> str:
    """E.g. "pendulum upright_fraction ↑"."""
    return f"{protocol.task} {protocol.metric} {'↑' if protocol.direction == 'maximize' else '↓'}"


def by_task(cells: list[Cell]) -> dict[str, dict[str, Cell]]:
    """{task: {entry: cell}}."""
    table: dict[str, dict[str, Cell]] = {}
    for cell in cells:
        table.setdefault(cell.task, {})[cell.entry] = cell
    return table


def rich_table(cells: list[Cell], protocols: dict[str, Protocol], title: str) -> Table:
    """One column per task, one row per entry, each task's winner in bold."""
    table = Table(title=title)
    table.add_column("optimizer")
    grid = by_task(cells)
    for task in grid:
        table.add_column(column_title(protocols[task]), justify="right")
    best = {task: winners(list(row.values()), protocols[task]) for task, row in grid.items()}
    for entry in entries_of(cells):
        texts = []
        for task, row in grid.items():
            cell = row.get(entry)
            texts.append(
                Text(
                    "-" if cell is None else cell.text(),
                    style="bold" if entry in best[task] else "",
                )
            )
        table.add_row(entry, *texts)
    return table


def markdown_table(cells: list[Cell], protocols: dict[str, Protocol]) -> str:
    """The table as GitHub markdown, each task's winner in bold."""
    grid = by_task(cells)
    best = {task: winners(list(row.values()), protocols[task]) for task, row in grid.items()}
    lines = [
        "| optimizer | " + " | ".join(column_title(protocols[task]) for task in grid) + " |",
        "|---|" + "---:|" * len(grid),
    ]
    for entry in entries_of(cells):
        texts = []
        for task, row in grid.items():
            cell = row.get(entry)
            text = "-" if cell is None else cell.text().replace("|", "/")
            texts.append(f"**{text}**" if entry in best[task] else text)
        lines.append(f"| {entry} | " + " | ".join(texts) + " |")
    return "\n".join(lines) + "\n"


def write_markdown(
    path: Path, cells: list[Cell], protocols: dict[str, Protocol], notes: list[str]
) -> None:
    """leaderboard.md: the table, each task's protocol, and `notes` (the command, the hours)."""
    parts = [markdown_table(cells, protocols), ""]
    parts += [f"- {protocol.task}: {protocol.line()}" for protocol in protocols.values()]
    parts += ["", *notes]
    write_text(path, "\n".join(parts) + "\n")


CSV_COLUMNS = (
    "task",
    "entry",
    "optimizer",
    "metric",
    "direction",
    "mean",
    "ci95",
    "min",
    "max",
    "n",
    "winner",
    "tuned_value",
    "defaults_value",
    "best_trial",
    "trials",
    "failed_trials",
    "plan_ms",
    "failure",
    "config",
    "params",
)


def write_csv(path: Path, cells: list[Cell], protocols: dict[str, Protocol]) -> None:
    """leaderboard.csv: one row per task x entry, CSV_COLUMNS (the validation's summary, the
    tuning's values)."""
    grid = by_task(cells)
    best = {task: winners(list(row.values()), protocols[task]) for task, row in grid.items()}
    try:
        with path.open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(CSV_COLUMNS)
            for cell in cells:
                protocol, summary = protocols[cell.task], cell.summary
                stats = (
                    []
                    if summary is None
                    else [summary.mean, summary.ci95, summary.min, summary.max, summary.n]
                )
                writer.writerow(
                    [
                        cell.task,
                        cell.entry,
                        cell.optimizer,
                        protocol.metric,
                        protocol.direction,
                        *(stats or [""] * 5),
                        cell.entry in best[cell.task],
                        "" if cell.tuned_value is None else cell.tuned_value,
                        "" if cell.defaults_value is None else cell.defaults_value,
                        "" if cell.best_trial is None else cell.best_trial,
                        cell.trials,
                        cell.failed_trials,
                        "" if cell.plan_ms is None else cell.plan_ms,
                        cell.failure or "",
                        cell.config or "",
                        " ".join(f"{name}={value}" for name, value in sorted(cell.params.items())),
                    ]
                )
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err


def write_plot(path: Path, cells: list[Cell], protocols: dict[str, Protocol], title: str) -> bool:
    """leaderboard.png: a panel per task, each entry's mean as a dot with its 95% interval as a bar
    (the winner filled in), so overlapping intervals show where the order is not settled. False
    without matplotlib."""
    plt = optional_pyplot()
    if plt is None:
        return False
    grid = by_task(cells)
    entries = entries_of(cells)
    figure, axes = plt.subplots(
        1, len(grid), figsize=(3.2 * len(grid) + 1.5, 0.4 * len(entries) + 1.6), squeeze=False
    )
    for axis, (task, row) in zip(axes[0], grid.items(), strict=True):
        best = winners(list(row.values()), protocols[task])
        for y, entry in enumerate(entries):
            cell = row.get(entry)
            summary = None if cell is None else cell.summary
            if summary is None:
                axis.text(
                    0.02,
                    y,
                    "failed" if cell is not None else "-",
                    transform=axis.get_yaxis_transform(),
                )
                continue
            error = 0.0 if math.isnan(summary.ci95) else summary.ci95
            filled = entry in best
            axis.errorbar(
                summary.mean,
                y,
                xerr=error,
                fmt="o",
                capsize=3,
                color="C3" if filled else "C0",
                mfc=None if filled else "w",
            )
        axis.set_yticks(range(len(entries)))
        axis.set_yticklabels(entries if axis is axes[0][0] else [""] * len(entries))
        axis.invert_yaxis()
        axis.set_title(column_title(protocols[task]), fontsize=9)
        axis.grid(axis="x", alpha=0.3)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    try:
        figure.savefig(path, dpi=100)
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err
    finally:
        plt.close(figure)
    return True


def record_run(out: Path, seconds: float, cpus: int, finished: bool) -> list[dict[str, Any]]:
    """Append this run's wall time and cores to out/runs.json; returns every run recorded there."""
    path = out / "runs.json"
    runs = json.loads(path.read_text()) if path.is_file() else []
    stamp = datetime.now(timezone.utc).isoformat(timespec="seconds")
    runs.append({"ended": stamp, "wall_s": round(seconds, 1), "cpus": cpus, "finished": finished})
    write_json(path, runs)
    return runs


def hours_line(runs: list[dict[str, Any]]) -> str:
    """E.g. "wall time 12:30 on 2 cores (0.42 core-hours held: wall time x cores); all 2 runs into
    this folder: 15:00, 0.50 core-hours": this run's, from Ray's start to the last validation, and
    every run's recorded."""
    last = runs[-1]
    line = (
        f"wall time {clock_time(last['wall_s'])} on {last['cpus']} cores "
        f"({last['wall_s'] * last['cpus'] / 3600:.2f} "
        "core-hours held: wall time x cores)"
    )
    if len(runs) > 1:
        total = sum(run["wall_s"] for run in runs)
        core_hours = sum(run["wall_s"] * run["cpus"] for run in runs) / 3600
        line += (
            f"; all {len(runs)} runs into this folder: {clock_time(total)}, {core_hours:.2f} "
            "core-hours"
        )
    return line


def write_text(path: Path, text: str) -> None:
    """Write `text` to `path`; JudoError if that fails."""
    try:
        path.write_text(text)
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err
