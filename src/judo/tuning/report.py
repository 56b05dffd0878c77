"""The outputs of a tune: the table of top trials, trials.csv, and the plots (PNG and HTML).

history.{png,html}      the objective of each trial and the best so far (infeasible trials greyed)
conditions.{png,html}   each condition's metric (mean over seeds) of each trial, with 2+ conditions
importance.{png,html}   each parameter's importance to the objective (fANOVA), from 2 completed trials on
best_episode.{png,html} the best trial's episode (seed 0), drawn by evaluate's plot code

HTML plots are plotly files with the library inlined (they open offline); PNGs are drawn with
matplotlib.
"""  # noqa: E501

import csv
import json
import math
import warnings
from pathlib import Path
from typing import Any

from rich.table import Table

from judo.cli_shared import optional_pyplot
from judo.core.errors import JudoError
from judo.tuning.heartbeat import failure_of
from judo.tuning.objective import Objective
from judo.tuning.space import Param
from judo.tuning.study import import_optuna, is_baseline, is_feasible, ranked_trials

LIMIT_HITS = "limit_hits"
"""Evaluate's metric of the [safety] limits' hits per episode (judo.evaluation.episode), shown
beside the score."""


def has_limit_hits(trials: list[Any]) -> bool:
    """Whether any trial ran under [safety] limits (its metrics have LIMIT_HITS)."""
    return any(LIMIT_HITS in trial.user_attrs.get("metrics", {}) for trial in trials)


def fmt(value: Any) -> str:
    """A short text for a number or other value."""
    if isinstance(value, float):
        return "n/a" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def top_trials_table(
    study: Any, objective: Objective, space: list[Param], count: int = 10
) -> Table:
    """The best `count` completed trials: value (and the mean limit hits per episode under [safety]
    limits), median plan time, feasibility and parameters."""
    trials = ranked_trials(study, objective)
    failed = len(study.get_trials(deepcopy=False, states=(import_optuna().trial.TrialState.FAIL,)))
    table = Table(
        title=f"top trials of {study.study_name}: {objective.metric} ({objective.direction})"
    )
    table.caption = f"{len(trials)} completed, {failed} failed"
    fields = [p.field for p in space]
    labels = [p.field if fields.count(p.field) == 1 else p.name for p in space]
    conditions = condition_labels(trials)
    shown = conditions if len(conditions) > 1 else []
    hits = ["limit hits"] if has_limit_hits(trials) else []
    for column in (
        "trial",
        objective.metric,
        *hits,
        *map(short_label, shown),
        "plan ms",
        "feasible",
        *labels,
    ):
        table.add_column(column, justify="left" if column in ("feasible",) else "right")
    for trial in trials[:count]:
        table.add_row(
            f"{trial.number} (defaults)" if is_baseline(trial) else str(trial.number),
            fmt(trial.value),
            *(fmt(trial.user_attrs.get("metrics", {}).get(LIMIT_HITS, math.nan)) for _ in hits),
            *(fmt(trial.user_attrs.get("conditions", {}).get(label, math.nan)) for label in shown),
            fmt(trial.user_attrs.get("plan_ms") or math.nan),
            "yes" if is_feasible(trial) else "no",
            *(fmt(trial.params.get(p.name, "")) for p in space),
        )
    return table


def short_label(label: str) -> str:
    """A condition's label for a table column: "control_freq=20 latency_ms=25" -> "20 Hz 25 ms"."""
    units = {"control_freq": "Hz", "latency_ms": "ms"}
    words = []
    for part in label.split():
        name, _, value = part.partition("=")
        words.append(f"{value} {units[name]}" if name in units else part)
    return " ".join(words)


def condition_labels(trials: list[Any]) -> list[str]:
    """The condition labels the trials were scored under, in order of first appearance."""
    return list(
        dict.fromkeys(label for trial in trials for label in trial.user_attrs.get("conditions", {}))
    )


def write_trials_csv(path: Path, study: Any, metric: str = "value") -> None:
    """One row per trial: number, state, value, under [safety] limits `limit_hits` (the mean hits
    per episode), the objective `metric` under each condition (a column `METRIC@LABEL` per
    condition), plan_ms, feasible, failure, each parameter and each other metric's mean."""
    trials = study.get_trials(deepcopy=False)
    params = list(dict.fromkeys(name for trial in trials for name in trial.params))
    metrics = list(
        dict.fromkeys(name for trial in trials for name in trial.user_attrs.get("metrics", {}))
    )
    hits = [LIMIT_HITS] if LIMIT_HITS in metrics else []
    metrics = [name for name in metrics if name not in hits]
    conditions = condition_labels(trials)
    header = [
        "number",
        "state",
        "value",
        *hits,
        *(f"{metric}@{label}" for label in conditions),
        "plan_ms",
        "feasible",
        "failure",
        *params,
        *(f"metric.{m}" for m in metrics),
    ]
    try:
        with path.open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(header)
            for trial in trials:
                writer.writerow(
                    [
                        trial.number,
                        trial.state.name,
                        "" if trial.value is None else trial.value,
                        *(trial.user_attrs.get("metrics", {}).get(name, "") for name in hits),
                        *(
                            trial.user_attrs.get("conditions", {}).get(label, "")
                            for label in conditions
                        ),
                        trial.user_attrs.get("plan_ms", ""),
                        is_feasible(trial),
                        failure_of(trial) or "",
                        *(trial.params.get(name, "") for name in params),
                        *(trial.user_attrs.get("metrics", {}).get(name, "") for name in metrics),
                    ]
                )
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err


def write_study_plots(out: Path, study: Any, objective: Objective) -> list[Path]:
    """history and (with 2+ completed trials) importance plots as PNG and HTML; returns the paths
    written."""
    optuna = import_optuna()
    from optuna.visualization import matplotlib as optuna_matplotlib

    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    if not complete:
        return []
    plots: list[tuple[str, Any, Any]] = [
        (
            "history",
            optuna.visualization.plot_optimization_history,
            optuna_matplotlib.plot_optimization_history,
        )
    ]
    if len(complete) >= 2 and complete[0].params:
        plots.append(
            (
                "importance",
                optuna.visualization.plot_param_importances,
                optuna_matplotlib.plot_param_importances,
            )
        )
    written = []
    for name, plotly_plot, matplotlib_plot in plots:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                figure = plotly_plot(study, target_name=objective.metric)
                figure.write_html(out / f"{name}.html", include_plotlyjs=True)
                written.append(out / f"{name}.html")
                written += write_png(out / f"{name}.png", matplotlib_plot, study, objective)
        # e.g. importances of constant values
        except (ValueError, RuntimeError, ZeroDivisionError) as err:
            (out / f"{name}.txt").write_text(f"no {name} plot: {err}\n")
    return written + write_conditions_plots(out, complete, objective)


def write_conditions_plots(out: Path, complete: list[Any], objective: Objective) -> list[Path]:
    """conditions.{html,png}: each condition's metric against the trial number, with 2+
    conditions."""
    labels = condition_labels(complete)
    if len(labels) < 2:
        return []
    import plotly.graph_objects as go

    numbers = [trial.number for trial in complete]
    series = {
        label: [trial.user_attrs.get("conditions", {}).get(label) for trial in complete]
        for label in labels
    }
    figure = go.Figure(
        [
            go.Scatter(x=numbers, y=ys, mode="lines+markers", name=label)
            for label, ys in series.items()
        ]
    )
    figure.update_layout(
        title=f"{objective.metric} under each condition (mean over seeds)",
        xaxis_title="trial",
        yaxis_title=objective.metric,
    )
    figure.write_html(out / "conditions.html", include_plotlyjs=True)
    written = [out / "conditions.html"]
    plt = optional_pyplot()
    if plt is None:
        return written
    figure, axes = plt.subplots(figsize=(8, 5))
    for label, ys in series.items():
        axes.plot(numbers, [math.nan if y is None else y for y in ys], marker="o", label=label)
    axes.set(
        xlabel="trial", ylabel=objective.metric, title=f"{objective.metric} under each condition"
    )
    axes.legend()
    figure.tight_layout()
    figure.savefig(out / "conditions.png", dpi=100)
    plt.close(figure)
    return [*written, out / "conditions.png"]


def write_png(path: Path, plot: Any, study: Any, objective: Objective) -> list[Path]:
    """Draw `plot` (an optuna.visualization.matplotlib function) to `path`; [] when matplotlib is
    missing."""
    plt = optional_pyplot()
    if plt is None:
        return []
    axes = plot(study, target_name=objective.metric)
    figure = axes.figure if hasattr(axes, "figure") else plt.gcf()
    figure.set_size_inches(8, 5)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return [path]


def before_after_line(objective: Objective, baseline: Any, best: Any | None) -> str:
    """One line comparing the trial that ran the defaults with the best trial."""
    before = (
        f"defaults (trial {baseline.number}): {objective.metric} {fmt(baseline.value)}, plan "
        f"{plan_text(baseline)}"
    )
    if best is None:
        return before + "; no feasible trial"
    if best.number == baseline.number:
        return before + "; no trial beat them"
    return before + f"; best (trial {best.number}): {fmt(best.value)}, plan {plan_text(best)}"


def plan_text(trial: Any) -> str:
    """The trial's median control update, e.g. "12.3 ms"."""
    return f"{fmt(trial.user_attrs.get('plan_ms') or math.nan)} ms"


def trial_summary(trial: Any | None) -> dict[str, Any] | None:
    """A trial's number, value, parameters, plan time and metrics, for summary.json."""
    if trial is None:
        return None
    return {
        "number": trial.number,
        "value": trial.value,
        "params": trial.params,
        "plan_ms": trial.user_attrs.get("plan_ms"),
        "conditions": trial.user_attrs.get("conditions"),
        "metrics": trial.user_attrs.get("metrics"),
    }


def write_summary_json(
    path: Path, study: Any, objective: Objective, best: Any | None, baseline: Any | None = None
) -> None:
    """The study's identity, its best trial and the trial that ran the defaults, as JSON (for
    scripts)."""
    content = {
        "study": study.study_name,
        **study.user_attrs,
        "direction": objective.direction,
        "best": trial_summary(best),
        "defaults": trial_summary(baseline),
    }
    path.write_text(json.dumps(content, indent=2, default=str) + "\n")
