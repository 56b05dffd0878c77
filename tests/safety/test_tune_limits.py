"""Tuning reports the [safety] limits' hits beside each trial's score: evaluate's limit_hits metric,
per episode."""

import csv

import pytest

from judo.tuning.objective import Objective
from judo.tuning.report import LIMIT_HITS, top_trials_table, write_trials_csv
from judo.tuning.space import Param
from judo.tuning.study import suggest, tell
from judo.tuning.trial import TrialSpec, run_trial

optuna = pytest.importorskip("optuna")

SPACE = [Param("optimizer", "sigma", 0.01, 1.0, log=True)]


def told(study, outcome):
    trial = study.ask()
    suggest(trial, SPACE)
    tell(study, trial, outcome, None)
    return study.trials[-1]


def rows(path):
    with path.open(newline="") as file:
        return list(csv.reader(file))


def test_a_trial_under_limits_has_its_limit_hits_beside_its_score(tmp_path):
    path = tmp_path / "limits.toml"
    path.write_text('[safety.cartpole]\nposition = ["slider=-0.05:0.05"]\nrate = ["push=5"]\n')
    spec = TrialSpec("cartpole", "ps", "mean_reward", seeds=1, duration=0.2, config_file=str(path))
    outcome = run_trial(spec, {"optimizer.sigma": 0.3})
    # evaluate's metric, the mean per episode
    assert outcome.failure is None and LIMIT_HITS in outcome.metrics
    study = optuna.create_study(direction="maximize")
    told(study, outcome)
    write_trials_csv(tmp_path / "trials.csv", study, "mean_reward")
    header, row = rows(tmp_path / "trials.csv")
    assert header[:4] == ["number", "state", "value", LIMIT_HITS]
    assert float(row[3]) == outcome.metrics[LIMIT_HITS] and f"metric.{LIMIT_HITS}" not in header
    table = top_trials_table(study, Objective("mean_reward", "maximize"), SPACE)
    assert [column.header for column in table.columns][:3] == ["trial", "mean_reward", "limit hits"]


def test_without_limits_no_column_is_added(tmp_path):
    study = optuna.create_study(direction="maximize")
    told(study, run_trial(TrialSpec("cartpole", "ps", "mean_reward", seeds=1, duration=0.2), {}))
    write_trials_csv(tmp_path / "trials.csv", study, "mean_reward")
    header, _ = rows(tmp_path / "trials.csv")
    assert (
        LIMIT_HITS not in header
        and f"metric.{LIMIT_HITS}" not in header
        and header[3] == "mean_reward@default"
    )
    table = top_trials_table(study, Objective("mean_reward", "maximize"), SPACE)
    assert "limit hits" not in [column.header for column in table.columns]
