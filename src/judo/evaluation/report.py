"""What `python -m judo evaluate` reports of its episodes: each metric's summary over seeds, the
table it prints (mean with 95% CI, min, max) and its caption, and each episode's JSON record."""

from typing import Any

import numpy as np
from rich.table import Table

from judo.evaluation.episode import EpisodeResult
from judo.evaluation.stats import Summary, shown_interval, summarize


def summarize_metrics(results: list[EpisodeResult]) -> dict[str, Summary]:
    """Each metric's summary over the episodes, in the order the task reports them."""
    names = list(dict.fromkeys(name for result in results for name in result.metrics))
    return {
        name: summarize(np.array([result.metrics.get(name, np.nan) for result in results]))
        for name in names
    }


def metrics_table(title: str, summaries: dict[str, Summary]) -> Table:
    """One row per metric: mean ± 95% CI, min and max over seeds."""
    table = Table(title=title)
    table.add_column("metric")
    table.add_column("mean ± 95% CI", justify="right")
    table.add_column("min", justify="right")
    table.add_column("max", justify="right")
    for name, summary in summaries.items():
        table.add_row(name, shown_interval(summary), f"{summary.min:.3g}", f"{summary.max:.3g}")
    return table


def update_caption(update_ms: np.ndarray, policy: bool) -> str:
    """The table's caption: the median control update in ms, or for a policy its inference in µs
    (observation, `act` and plan; the same span of the loop's update)."""
    if policy:
        return (
            f"policy inference: median {1e3 * np.median(update_ms):.1f} µs per update over "
            f"{len(update_ms)} updates"
        )
    return f"control update: median {np.median(update_ms):.2f} ms over {len(update_ms)} updates"


def episode_record(result: EpisodeResult) -> dict[str, Any]:
    """The JSON record of one episode."""
    return {
        "seed": result.seed,
        "metrics": result.metrics,
        "num_updates": len(result.update_ms),
        "update_ms_median": float(np.median(result.update_ms)) if len(result.update_ms) else None,
        "latency_ms_median": float(1e3 * np.median(result.latency_s))
        if len(result.latency_s)
        else None,
        "failed_updates": result.failed_updates,
        "divergences": result.divergences,
        **(
            {"limit_hits": result.limit_hits, "no_feasible": result.no_feasible}
            if "limit_hits" in result.metrics
            else {}
        ),
    }
