"""One trial without Ray: evaluate's seeded episodes with the trial's values, and failures recorded
with their reason."""

import math

import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import EpisodeResult, episode_failure
from judo.evaluation.evaluate import EvaluateArgs, evaluate
from judo.tuning.objective import UnknownMetricError, make_objective, metric_direction
from judo.tuning.trial import TrialSpec, run_trial
from tests.conftest import TINY_CARTPOLE_XML, UprightConfig, UprightTask

CARTPOLE = TrialSpec("cartpole", "ps", "balanced_fraction", seeds=2, duration=0.4)


def test_a_trial_with_the_default_settings_gives_evaluates_result():
    outcome = run_trial(CARTPOLE, {})
    results = evaluate(EvaluateArgs("cartpole", "ps", seeds=2, duration=0.4, num_workers=1))
    assert outcome.failure is None
    assert outcome.metrics["mean_reward"] == pytest.approx(
        np.mean([r.metrics["mean_reward"] for r in results])
    )
    assert outcome.value == outcome.metrics["balanced_fraction"]
    assert outcome.plan_ms > 0


def test_a_trial_from_a_first_seed_runs_evaluates_episodes_of_those_seeds():
    spec = TrialSpec("cartpole", "ps", "balanced_fraction", seeds=2, duration=0.4, first_seed=7)
    assert list(spec.seed_range()) == [7, 8]
    outcome = run_trial(spec, {})
    results = evaluate(
        EvaluateArgs("cartpole", "ps", seeds=2, first_seed=7, duration=0.4, num_workers=1)
    )
    assert [result.seed for result in results] == [7, 8]
    assert outcome.metrics["mean_reward"] == pytest.approx(
        np.mean([r.metrics["mean_reward"] for r in results])
    )


def test_the_trials_values_reach_the_episodes():
    default, other = (
        run_trial(CARTPOLE, {}),
        run_trial(CARTPOLE, {"optimizer.sigma": 1.5, "task.w_centered": 0.0}),
    )
    assert other.failure is None
    assert other.metrics["mean_reward"] != default.metrics["mean_reward"]


def test_values_the_configs_refuse_fail_the_trial_with_the_reason():
    outcome = run_trial(
        TrialSpec("cartpole", "cem", "mean_reward", 1, 0.2),
        {"optimizer.sigma_min": 0.9, "optimizer.sigma_max": 0.1},
    )
    assert outcome.failed and math.isnan(outcome.value)
    assert outcome.failure is not None and outcome.failure.startswith("ConfigError: ")
    assert "sigma_min" in outcome.failure


@pytest.fixture
def exploding_task(tmp_path):
    """A registered task whose reward raises."""
    model = tmp_path / "tiny.xml"
    model.write_text(TINY_CARTPOLE_XML)

    class ExplodingTask(UprightTask):
        def __init__(self):
            super().__init__(model)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            raise FloatingPointError("the reward blew up")

    judo.register_task("tune_exploding_task", ExplodingTask, UprightConfig)
    return "tune_exploding_task"


def test_an_exception_in_the_users_task_fails_the_trial_and_names_it(exploding_task):
    outcome = run_trial(TrialSpec(exploding_task, "ps", "mean_reward", 1, 0.2), {})
    assert outcome.failure is not None
    assert outcome.failure.startswith("FloatingPointError: the reward blew up (test_tune_trial.py:")


def test_diverged_and_non_finite_episodes_are_failures():
    log = EpisodeLog(np.zeros(1), np.zeros((1, 4)), np.zeros((1, 1)), np.zeros((1, 0)))

    def result(**changes):
        fields = dict(
            seed=3,
            log=log,
            rewards=np.zeros(1),
            metrics={"mean_reward": 0.0},
            update_ms=np.ones(1),
            latency_s=np.zeros(1),
            failed_updates=0,
            divergences=0,
        )
        return EpisodeResult(**{**fields, **changes})

    assert episode_failure(result()) is None
    assert episode_failure(result(divergences=2)) == "seed 3: the simulation diverged 2 times"
    assert episode_failure(result(failed_updates=1)) == (
        "seed 3: 1 control updates had no finite reward"
    )
    assert episode_failure(result(metrics={"mean_reward": math.nan})) == (
        "seed 3: non-finite mean_reward"
    )


def test_directions_come_from_the_tasks_lower_is_better():
    assert metric_direction("cylinder_push", "final_distance") == "minimize"
    assert metric_direction("cylinder_push", "reached") == "maximize"
    assert metric_direction("leap_cube_down", "drops") == "minimize"  # inherited from leap_cube
    assert make_objective("cartpole", None, ["swung_up", "mean_reward"]).metric == "mean_reward"


def test_an_unknown_metric_lists_the_tasks_metrics():
    with pytest.raises(
        UnknownMetricError,
        match=r"^task 'cartpole' reports no "
        r"metric 'upright'; its metrics are: ",
    ):
        make_objective("cartpole", "upright", ["balanced_fraction", "swung_up", "mean_reward"])
