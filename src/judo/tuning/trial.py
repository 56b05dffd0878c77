"""One trial: the task x optimizer with the trial's settings, over seeded closed-loop episodes.

The episodes are evaluate's (`judo.evaluation.seeded.run_seeded_episode`, the one seeded episode
runner), one per seed and condition (tuning/conditions.py), with the same latency options.
`run_condition_seed` is what each Ray task runs and `score_trial` combines a trial's episodes;
neither raises: an exception, a non-finite metric, a diverged simulation or an update with no finite
reward makes the outcome failed, with the reason.
"""

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from judo.evaluation.episode import EpisodeOutcome, EpisodeResult, episode_failure
from judo.evaluation.seeded import EpisodeSpec, failure_reason, run_seeded_episode
from judo.evaluation.sensing import Sensing
from judo.loop.timing import Latency
from judo.tuning.conditions import Aggregate, Condition


@dataclass(frozen=True)
class TrialSpec:
    """What every trial of a study shares.

    Attributes:
        task, optimizer: registered names.
        metric: the metric averaged over seeds as the trial's value.
        seeds: episodes per trial, with seeds first_seed to first_seed + seeds - 1.
        duration: seconds of sim time per episode.
        latency: as for run_episode: seconds of sim time, or "measured".
        config_file: the user's --config file (read once per process), or None.
        fixed: --fix values, {`kind.field`: value}, applied under the trial's own values.
        num_workers: rollout threads per trial (1, so that parallel trials do not fight for cores).
        conditions: the episode settings each seed runs under (tuning/conditions.py); one condition
            that sets nothing runs the study's latency at the task's rate.
        aggregate, cvar_alpha: how the conditions' metrics become the trial's value.
        maximize: whether the metric is better higher (which condition is the worst).
        sensing: how every episode's plant is observed and
            estimated (--observe, --sensor-*, --estimator).
        first_seed: the seed of each condition's first episode (tune --first-seed).
        plant_overrides: --plant-overrides entries (FIELD.ELEMENT=VALUE), the simulated plant's
            model fields.
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
    conditions: tuple[Condition, ...] = (Condition(),)
    aggregate: Aggregate = "mean"
    cvar_alpha: float = 0.5
    maximize: bool = True
    sensing: Sensing = field(default_factory=Sensing)
    first_seed: int = 0
    plant_overrides: tuple[str, ...] = ()

    def seed_range(self) -> range:
        """The seeds every condition of a trial runs: first_seed to first_seed + seeds - 1."""
        return range(self.first_seed, self.first_seed + self.seeds)


@dataclass
class TrialOutcome:
    """What a trial measured.

    Attributes:
        value: the metric's mean over seeds (NaN when failed).
        metrics: every metric's mean over seeds and conditions.
        plan_ms: the median control update over all episodes' updates, in milliseconds.
        failure: why the trial failed, or None.
        conditions: the metric's mean over seeds under each condition, by Condition.label.
    """

    value: float
    metrics: dict[str, float]
    plan_ms: float
    failure: str | None = None
    conditions: dict[str, float] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """Whether the trial failed."""
        return self.failure is not None


def run_seeded_episodes(
    spec: TrialSpec, values: dict[str, Any], seeds: range, condition: Condition | None = None
) -> list[EpisodeResult]:
    """One episode per seed with `values` ({`kind.field`: value}) over the fixed ones, each by the
    one seeded episode runner (`judo.evaluation.seeded.run_seeded_episode`); raises on failure.

    `condition` (None: `spec.conditions[0]`) sets the controller's control_freq and the latency.
    """
    condition = spec.conditions[0] if condition is None else condition
    updates = {**spec.fixed, **values}
    if condition.control_freq is not None:
        updates["controller.control_freq"] = condition.control_freq
    latency = spec.latency if condition.latency_ms is None else condition.latency_ms / 1e3
    episode = EpisodeSpec(
        spec.task,
        spec.optimizer,
        spec.duration,
        latency,
        updates,
        spec.config_file,
        num_workers=spec.num_workers,
        sensing=spec.sensing,
        plant_overrides=spec.plant_overrides,
    )
    return [run_seeded_episode(episode, seed) for seed in seeds]


def run_condition_seed(
    spec: TrialSpec, values: dict[str, Any], condition: int, seed: int
) -> EpisodeOutcome[None]:
    """Run one episode of the trial (seed `seed` under condition number `condition`), what each Ray
    task of a study runs; never raises. A failed control update fails the episode, and so the trial
    (`episode_failure`)."""
    try:
        (result,) = run_seeded_episodes(
            spec, values, range(seed, seed + 1), spec.conditions[condition]
        )
    except Exception as err:  # a user's task may raise anything; the study goes on
        return EpisodeOutcome.failed(seed, failure_reason(err), condition)
    return EpisodeOutcome.of(
        result, None, episode_failure(result, failed_updates_fail=True), condition
    )


def score_trial(spec: TrialSpec, episodes: list[EpisodeOutcome[None]]) -> TrialOutcome:
    """The trial's outcome from all its episodes: each condition's mean of `spec.metric` over seeds,
    aggregated by `spec.aggregate`; `metrics` are means over every episode. Failed when any episode
    failed."""
    from judo.tuning.conditions import aggregate

    labels = [condition.label for condition in spec.conditions]
    episodes = sorted(episodes, key=lambda episode: (episode.condition, episode.seed))
    for episode in episodes:
        if episode.failure is not None:
            where = f"{labels[episode.condition]}: " if len(labels) > 1 else ""
            return TrialOutcome(math.nan, {}, math.nan, where + episode.failure)
    names = list(dict.fromkeys(name for episode in episodes for name in episode.metrics))
    metrics = {
        name: float(np.mean([episode.metrics.get(name, np.nan) for episode in episodes]))
        for name in names
    }
    update_ms = (
        np.concatenate([episode.update_ms for episode in episodes]) if episodes else np.zeros(0)
    )
    plan_ms = float(np.median(update_ms)) if len(update_ms) else math.nan
    per_condition = {
        label: float(
            np.mean([e.metrics.get(spec.metric, np.nan) for e in episodes if e.condition == index])
        )
        for index, label in enumerate(labels)
    }
    value = aggregate(list(per_condition.values()), spec.aggregate, spec.maximize, spec.cvar_alpha)
    failure = None if math.isfinite(value) else f"metric {spec.metric!r} is {value}"
    return TrialOutcome(value, metrics, plan_ms, failure, per_condition)


def run_trial(spec: TrialSpec, values: dict[str, Any]) -> TrialOutcome:
    """Run every episode of the trial here, one after another (a study runs each as its own Ray
    task); never raises."""
    episodes = [
        run_condition_seed(spec, values, condition, seed)
        for condition in range(len(spec.conditions))
        for seed in spec.seed_range()
    ]
    return score_trial(spec, episodes)
