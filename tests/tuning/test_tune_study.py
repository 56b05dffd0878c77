"""The study's bookkeeping without Ray: told outcomes, --max-plan-ms feasibility, the best trial,
the grid."""

import pytest

from judo.tuning.objective import Objective
from judo.tuning.space import Param
from judo.tuning.study import (
    best_trial,
    grid_values,
    is_feasible,
    make_sampler,
    ranked_trials,
    suggest,
    tell,
)
from judo.tuning.trial import TrialOutcome

optuna = pytest.importorskip("optuna")

SPACE = [
    Param("optimizer", "sigma", 0.01, 1.0, log=True),
    Param("optimizer", "num_nodes", 2, 6, integer=True),
]


def told(study, outcome, max_plan_ms=None):
    trial = study.ask()
    suggest(trial, SPACE)
    tell(study, trial, outcome, max_plan_ms)
    return study.trials[-1]


def test_slower_trials_are_infeasible_not_dropped_and_never_best():
    objective = Objective("swung_up", "maximize")
    study = optuna.create_study(
        direction="maximize", sampler=make_sampler("tpe", 0, SPACE, constrained=True)
    )
    fast = told(study, TrialOutcome(0.5, {"swung_up": 0.5}, plan_ms=3.0), max_plan_ms=5.0)
    slow = told(study, TrialOutcome(1.0, {"swung_up": 1.0}, plan_ms=9.0), max_plan_ms=5.0)
    assert fast.state.name == slow.state.name == "COMPLETE"
    assert (is_feasible(fast), is_feasible(slow)) == (True, False)
    assert slow.user_attrs["constraint"] == [4.0] and slow.user_attrs["plan_ms"] == 9.0
    assert [trial.number for trial in ranked_trials(study, objective)] == [fast.number, slow.number]
    assert best_trial(study, objective).number == fast.number


def test_a_failed_outcome_is_stored_as_failed_with_its_reason():
    study = optuna.create_study(direction="minimize")
    failed = told(
        study,
        TrialOutcome(float("nan"), {}, float("nan"), "seed 1: the simulation diverged 2 times"),
    )
    assert failed.state.name == "FAIL"
    assert failed.user_attrs["failure"] == "seed 1: the simulation diverged 2 times"
    assert best_trial(study, Objective("final_distance", "minimize")) is None
    good = told(study, TrialOutcome(0.02, {"final_distance": 0.02}, 1.0))
    assert best_trial(study, Objective("final_distance", "minimize")).number == good.number


def test_the_grid_spaces_values_as_the_parameter_is_searched():
    assert grid_values(SPACE[0]) == pytest.approx([0.01, 0.1, 1.0])
    assert grid_values(SPACE[1]) == [2, 4, 6]
    assert grid_values(Param("controller", "spline_order", choices=("zero", "cubic"))) == [
        "zero",
        "cubic",
    ]


def test_samplers_are_seeded():
    first = [suggest(trial, SPACE) for trial in ask_three(make_sampler("random", 7, SPACE, False))]
    again = [suggest(trial, SPACE) for trial in ask_three(make_sampler("random", 7, SPACE, False))]
    assert first == again


def ask_three(sampler):
    study = optuna.create_study(sampler=sampler)
    return [study.ask() for _ in range(3)]
