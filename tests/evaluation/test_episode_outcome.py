"""The one episode outcome and its one failure rule: an episode whose controller failed some control
updates is a failed tune episode, a kept collect episode, and an evaluate episode reported as it
ran."""

import numpy as np
import pytest

from judo.collection.episode import collect_episode
from judo.core.configuration.registry import register_task
from judo.evaluation.episode import episode_failure
from judo.evaluation.seeded import EpisodeSpec, evaluate_seed, run_seeded_episode
from judo.tuning.trial import TrialSpec, run_condition_seed
from tests.conftest import TINY_CARTPOLE_XML, UprightConfig, UprightTask

FAILED_PLANS = 2
"""Planning calls whose rollouts all score NaN, so that those control updates fail."""


@pytest.fixture
def failing_task(tmp_path):
    """A registered tiny cart-pole task whose first FAILED_PLANS plans score NaN for every rollout;
    the one-step rewards of the log (a batch of one rollout) stay finite, so the metrics do too."""
    path = tmp_path / "tiny.xml"
    path.write_text(TINY_CARTPOLE_XML)

    class FailingAtFirst(UprightTask):
        def __init__(self):
            super().__init__(path)
            self.plans = 0

        def reward(self, states, sensors, controls, config, system_metadata=None):
            rewards = super().reward(states, sensors, controls, config, system_metadata)
            if len(states) > 1:  # a plan's rollouts, not the log's one-step reward
                self.plans += 1
                if self.plans <= FAILED_PLANS:
                    return np.full_like(rewards, np.nan)
            return rewards

    register_task("failing_at_first", FailingAtFirst, UprightConfig)
    return "failing_at_first"


def test_failed_updates_fail_a_tune_episode_but_not_a_collect_or_evaluate_one(failing_task):
    spec = EpisodeSpec(failing_task, "ps", 0.2, num_workers=1)
    result = run_seeded_episode(spec, 4)
    assert result.failed_updates == FAILED_PLANS < len(result.update_ms)
    assert np.isfinite(list(result.metrics.values())).all() and result.divergences == 0
    reason = f"seed 4: {FAILED_PLANS} control updates had no finite reward"
    assert episode_failure(result) == reason
    assert episode_failure(result, failed_updates_fail=False) is None

    trial = run_condition_seed(
        TrialSpec(failing_task, "ps", "mean_reward", 1, 0.2, first_seed=4), {}, 0, 4
    )
    assert (trial.seed, trial.failure, trial.failed_updates) == (4, reason, FAILED_PLANS)

    kept = collect_episode(spec, 4)
    assert kept.failure is None and kept.episode is not None
    assert (kept.failed_updates, kept.num_updates) == (FAILED_PLANS, len(result.update_ms))
    assert kept.metrics == result.metrics  # the same episode, kept with its failed updates counted

    evaluated = evaluate_seed(spec, 4)
    assert evaluated.failure is None and evaluated.episode is not None
    assert evaluated.episode.failed_updates == evaluated.failed_updates == FAILED_PLANS
    np.testing.assert_array_equal(evaluated.episode.rewards, result.rewards)


def test_a_diverged_or_non_finite_episode_fails_whatever_the_failed_updates_rule(failing_task):
    result = run_seeded_episode(EpisodeSpec(failing_task, "ps", 0.1, num_workers=1), 0)
    result.failed_updates, result.divergences = 0, 1
    for failed_updates_fail in (True, False):
        assert episode_failure(result, failed_updates_fail) == (
            "seed 0: the simulation diverged 1 times"
        )
    result.divergences, result.metrics = 0, {**result.metrics, "mean_reward": np.nan}
    for failed_updates_fail in (True, False):
        assert episode_failure(result, failed_updates_fail) == "seed 0: non-finite mean_reward"
