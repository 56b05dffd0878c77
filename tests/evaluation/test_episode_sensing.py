"""Rehearsed sensing in the one seeded episode runner: evaluate, tune and collect plan from the
task's measured sensors through the estimator when asked (--observe sensors, --sensor-*,
--estimator), with real MuJoCo physics and the real EKF."""

import json

import numpy as np

from judo.evaluation.evaluate import main as evaluate_main
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.evaluation.sensing import Sensing
from judo.loop.records import PlanRecord, StepRecord
from judo.tuning.trial import TrialSpec, run_seeded_episodes

ENCODERS = Sensing("sensors", noise=0.005, delay=0.01, rate=100.0)
"""The encoder setting of docs/estimation.md: std 0.005 rad, 100 Hz, 10 ms late (the EKF by
default)."""


class Steps:
    """Keeps every StepRecord of an episode."""

    def __init__(self) -> None:
        self.records: list[StepRecord] = []

    def on_plan(self, record: PlanRecord) -> None:
        """Plans are not kept."""

    def on_step(self, record: StepRecord) -> None:
        self.records.append(record)


def run_with_steps(spec: EpisodeSpec, seed: int = 0) -> tuple[dict[str, float], list[StepRecord]]:
    steps = Steps()
    result = run_seeded_episode(spec, seed, recorders=lambda controller, plant: [steps])
    return result.metrics, steps.records


def test_an_episode_on_sensors_plans_from_the_ekf_estimate_and_logs_the_true_state():
    metrics, records = run_with_steps(EpisodeSpec("cartpole", "ps", 1.0, sensing=ENCODERS))
    assert all(record.measured is not None and record.estimate is not None for record in records)
    assert records[0].measured.shape == (2,)  # cartpole's two joint encoders
    settled = len(records) // 5  # after the filter's first 0.2 s
    true = np.array([record.state for record in records])[settled:]
    estimate = np.array([record.estimate for record in records])[settled:]
    position_error = np.abs(estimate[:, :2] - true[:, :2])
    assert position_error.mean() < 0.02, position_error.mean()
    measured = np.array([record.measured for record in records])[settled:]
    # noisy, late readings, not the truth
    assert 0.001 < np.abs(measured - true[:, :2]).mean() < 0.05
    assert set(metrics) >= {"balanced_fraction", "mean_reward"}


def test_sensing_episodes_are_seeded_and_differ_from_full_state_ones():
    spec = EpisodeSpec("cartpole", "ps", 0.5, sensing=ENCODERS)
    first, again = run_with_steps(spec)[1], run_with_steps(spec)[1]
    np.testing.assert_array_equal(first[-1].state, again[-1].state)
    np.testing.assert_array_equal(first[-1].measured, again[-1].measured)
    full_state = run_with_steps(EpisodeSpec("cartpole", "ps", 0.5))[1]
    assert full_state[-1].estimate is None and full_state[-1].measured is None
    assert not np.array_equal(full_state[-1].state, first[-1].state)


def test_a_tune_trial_runs_its_episodes_with_the_study_sensing():
    trial = TrialSpec("cartpole", "ps", "mean_reward", 1, 0.3, sensing=ENCODERS)
    (result,) = run_seeded_episodes(trial, {}, range(1))
    expected = run_seeded_episode(EpisodeSpec("cartpole", "ps", 0.3, sensing=ENCODERS), 0)
    assert result.metrics == expected.metrics
    assert result.metrics != run_seeded_episode(EpisodeSpec("cartpole", "ps", 0.3), 0).metrics


def test_evaluate_merges_repeated_sensor_flags_and_records_the_sensing(tmp_path, capsys):
    out = tmp_path / "metrics.json"
    argv = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--seeds",
        "1",
        "--duration",
        "0.2",
        "--observe",
        "sensors",
    ]
    argv += [
        "--sensor-rate-hz",
        "100",
        "--sensor-rate-hz",
        "jointpos=50",
        "--sensor-delay-ms",
        "10",
        "--json",
        str(out),
    ]
    assert evaluate_main(argv) == 0
    sensing = json.loads(out.read_text())["sensing"]
    assert sensing == {
        "observe": "sensors",
        "noise": None,
        "delay_s": 0.01,
        "rate_hz": {"default": 100.0, "jointpos": 50.0},
        "estimator": "ekf",
    }
    # the table title, however wrapped
    assert "sensors + ekf" in " ".join(capsys.readouterr().out.split())
