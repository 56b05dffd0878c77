"""One trial: the task x optimizer with the trial's settings, over seeded closed-loop episodes.

The episodes are evaluate's (`judo.evaluation.seeded.run_seeded_episode`), one per seed, with the same
latency options. `run_trial` is what each Ray task runs; it never raises: an exception, a non-finite metric, a diverged simulation or an update with no finite reward makes the
outcome failed, with the reason.
"""

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from judo.evaluation.episode import EpisodeResult, Latency
from judo.evaluation.seeded import EpisodeSpec, failure_reason, run_seeded_episode


@dataclass(frozen=True)
class TrialSpec:
    """What every trial of a study shares.

    Attributes:
        task, optimizer: registered names.
        metric: the metric averaged over seeds as the trial's value.
        seeds: episodes per trial, with seeds 0 to seeds - 1.
        duration: seconds of sim time per episode.
        latency: as for run_episode: seconds of sim time, or "measured".
        config_file: the user's --config file (read once per process), or None.
        fixed: --fix values, {`kind.field`: value}, applied under the trial's own values.
        num_workers: rollout threads per trial (1, so that parallel trials do not fight for cores).
    """

    task: str
    optimizer: str
    metric: str
    seeds: int
    duration: float
    latency: Latency = 0.0
    config_file: str | None = None
    fixed: dict[str, Any] = field(default_factory=dict)
    num_workers: int = 1


@dataclass
class TrialOutcome:
    """What a trial measured.

    Attributes:
        value: the metric's mean over seeds (NaN when failed).
        metrics: every metric's mean over seeds.
        plan_ms: the median control update over all episodes' updates, in milliseconds.
        failure: why the trial failed, or None.
    """

    value: float
    metrics: dict[str, float]
    plan_ms: float
    failure: str | None = None

    @property
    def failed(self) -> bool:
        """Whether the trial failed."""
        return self.failure is not None


def run_seeded_episodes(spec: TrialSpec, values: dict[str, Any], seeds: range) -> list[EpisodeResult]:
    """One episode per seed with `values` ({`kind.field`: value}) over the fixed ones, each by the one seeded
    episode runner (`judo.evaluation.seeded.run_seeded_episode`); raises on failure."""
    episode = EpisodeSpec(
        spec.task,
        spec.optimizer,
        spec.duration,
        spec.latency,
        {**spec.fixed, **values},
        spec.config_file,
        num_workers=spec.num_workers,
    )
    return [run_seeded_episode(episode, seed) for seed in seeds]


def episode_failure(result: EpisodeResult) -> str | None:
    """Why an episode counts as failed (diverged, no finite reward, a non-finite metric), or None."""
    if result.divergences:
        return f"seed {result.seed}: the simulation diverged {result.divergences} times"
    if result.failed_updates:
        return f"seed {result.seed}: {result.failed_updates} control updates had no finite reward"
    bad = [name for name, value in result.metrics.items() if not math.isfinite(value)]
    if bad:
        return f"seed {result.seed}: non-finite {', '.join(bad)}"
    return None


def run_trial(spec: TrialSpec, values: dict[str, Any]) -> TrialOutcome:
    """Run the trial's episodes and average `spec.metric` over seeds; never raises."""
    try:
        results = run_seeded_episodes(spec, values, range(spec.seeds))
    except Exception as err:  # noqa: BLE001  (a user's task may raise anything; the study goes on)
        return TrialOutcome(math.nan, {}, math.nan, failure_reason(err))
    names = list(dict.fromkeys(name for result in results for name in result.metrics))
    metrics = {name: float(np.mean([result.metrics.get(name, np.nan) for result in results])) for name in names}
    update_ms = np.concatenate([result.update_ms for result in results])
    plan_ms = float(np.median(update_ms)) if len(update_ms) else math.nan
    failure = next((reason for result in results if (reason := episode_failure(result))), None)
    value = metrics.get(spec.metric, math.nan)
    if failure is None and not math.isfinite(value):
        failure = f"metric {spec.metric!r} is {value}"
    return TrialOutcome(value, metrics, plan_ms, failure)
