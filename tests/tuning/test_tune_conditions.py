"""The conditions a tune scores a trial under: parsing and its errors, the task's check set, the
aggregates, and how a trial's episodes become its value."""

import math

import numpy as np
import pytest

from judo.evaluation.episode import EpisodeOutcome
from judo.tuning.conditions import (
    Condition,
    ConditionError,
    aggregate,
    check_conditions,
    parse_conditions,
)
from judo.tuning.trial import TrialSpec, score_trial
from judo.tuning.tune_args import TuneArgs


def test_lists_are_crossed_by_default_and_paired_when_listed():
    crossed = parse_conditions(["latency_ms=0,25,50", "control_freq=20,50"])
    assert [c.label for c in crossed] == [
        "control_freq=20 latency_ms=0",
        "control_freq=50 latency_ms=0",
        "control_freq=20 latency_ms=25",
        "control_freq=50 latency_ms=25",
        "control_freq=20 latency_ms=50",
        "control_freq=50 latency_ms=50",
    ]
    listed = parse_conditions(["latency_ms=0,25", "control_freq=50,20"], "listed")
    assert listed == [Condition(50.0, 0.0), Condition(20.0, 25.0)]
    assert parse_conditions(["control_freq=20,20,50"]) == [Condition(20.0), Condition(50.0)]
    assert parse_conditions([]) == []


@pytest.mark.parametrize(
    ("entries", "mode", "message"),
    [
        (["latncy_ms=0,25"], "crossed", "--conditions 'latncy_ms=0,25': "
                                        "unknown condition 'latncy_ms'; "
         "valid conditions are: control_freq, latency_ms"),
        (["latency_ms"], "crossed", "--conditions 'latency_ms': expected "
                                    "latency_ms=VALUE[,VALUE...] with "
                                    "numbers, "
         "e.g. latency_ms=0,25,50"),
        (["control_freq=20,fast"], "crossed", "--conditions 'control_freq=20,fast': expected "
         "control_freq=VALUE[,VALUE...] with numbers, e.g. control_freq=20,50"),
        (["control_freq=0"], "crossed", "--conditions 'control_freq=0': "
                                        "control_freq must be a positive rate in Hz, "
         "got 0"),
        (["latency_ms=-5"], "crossed", "--conditions 'latency_ms=-5': latency_ms "
                                       "must be from 0 to 60000 ms, got -5"),
        (["control_freq=20", "control_freq=50"], "crossed", "--conditions names control_freq "
                                                            "twice; give all its "
         "values once, e.g. control_freq=20,50"),
        (["latency_ms=0,25,50", "control_freq=20,50"], "listed", "--conditions-mode listed "
                                                                 "pairs the i-th values of "
         "each name, so every list needs the same length; latency_ms has 3, control_freq has 2"),
        (["control_freq=20"], "zipped", "unknown --conditions-mode 'zipped'; "
                                        "valid modes are: crossed, listed"),
    ],
)  # fmt: skip
def test_bad_conditions_say_what_was_expected(entries, mode, message):
    with pytest.raises(ConditionError) as error:
        parse_conditions(entries, mode)
    assert str(error.value) == message


def test_the_check_set_is_20_hz_and_the_tasks_rate_with_no_latency_and_its_check_latency():
    assert [c.label for c in check_conditions("cartpole")] == [
        "control_freq=20 latency_ms=0",
        "control_freq=20 latency_ms=25",
        "control_freq=50 latency_ms=0",
        "control_freq=50 latency_ms=25",
    ]
    # Acrobot.min_control_freq: its own 50 Hz
    assert [c.label for c in check_conditions("acrobot")] == [
        "control_freq=50 latency_ms=0",
        "control_freq=50 latency_ms=25",
    ]
    # its minimum, its own
    assert {c.control_freq for c in check_conditions("double_cartpole")} == {40.0, 50.0}
    assert {c.latency_ms for c in check_conditions("leap_cube_down")} == {0.0, 50.0}
    assert {c.latency_ms for c in check_conditions("fr3_pick")} == {0.0, 50.0}


def test_aggregates_take_the_mean_the_worst_or_the_mean_of_the_worst_fraction():
    values = [1.0, 0.2, 0.6, 0.9]
    assert aggregate(values, "mean", maximize=True) == pytest.approx(0.675)
    assert aggregate(values, "worst", maximize=True) == 0.2
    assert aggregate(values, "worst", maximize=False) == 1.0  # a distance: the highest is the worst
    assert aggregate(values, "cvar", maximize=True, alpha=0.5) == pytest.approx(0.4)  # 0.2 and 0.6
    # 1.0 and 0.9
    assert aggregate(values, "cvar", maximize=False, alpha=0.5) == pytest.approx(0.95)
    assert aggregate(values, "cvar", maximize=True, alpha=0.1) == 0.2  # at least one condition
    assert aggregate(values, "cvar", maximize=True, alpha=1.0) == pytest.approx(0.675)
    assert math.isnan(aggregate([0.5, math.nan], "mean", maximize=True))
    with pytest.raises(
        ConditionError,
        match=r"unknown --aggregate 'median'; valid "
        r"aggregates are: mean, worst, cvar",
    ):
        aggregate(values, "median", maximize=True)  # type: ignore[arg-type]
    with pytest.raises(ConditionError, match=r"--cvar-alpha must be in \(0, 1\], got 0"):
        aggregate(values, "cvar", maximize=True, alpha=0.0)


def test_a_trials_value_aggregates_each_conditions_mean_over_seeds():
    conditions = (Condition(20.0, 0.0), Condition(50.0, 0.0))
    spec = TrialSpec(
        "cartpole", "ps", "balanced_fraction", 2, 1.0, conditions=conditions, aggregate="worst"
    )
    fractions = {(0, 0): 0.4, (0, 1): 0.6, (1, 0): 1.0, (1, 1): 0.9}
    episodes = [
        EpisodeOutcome(c, s, {"balanced_fraction": f, "swung_up": 1.0}, np.array([2.0, 4.0]))
        for (c, s), f in fractions.items()
    ]
    outcome = score_trial(spec, episodes[::-1])  # the order episodes finish in does not matter
    assert outcome.conditions == pytest.approx(
        {"control_freq=20 latency_ms=0": 0.5, "control_freq=50 latency_ms=0": 0.95}
    )
    assert outcome.value == pytest.approx(0.5) and outcome.failure is None
    assert outcome.metrics == pytest.approx({"balanced_fraction": 0.725, "swung_up": 1.0})
    assert outcome.plan_ms == 3.0
    episodes[3] = EpisodeOutcome(1, 1, {}, np.zeros(0), "seed 1: the simulation diverged 2 times")
    failed = score_trial(spec, episodes)
    assert failed.failed and failed.failure == (
        "control_freq=50 latency_ms=0: seed 1: the simulation diverged 2 times"
    )


def test_latency_ms_is_one_condition_or_folds_into_the_conditions():
    args = TuneArgs("cartpole", "ps", latency_ms=25.0)
    assert args.condition_list() == [Condition(None, 25.0)]
    args = TuneArgs("cartpole", "ps", latency_ms=25.0, conditions=("control_freq=20,50",))
    assert args.condition_list() == [Condition(20.0, 25.0), Condition(50.0, 25.0)]
    assert TuneArgs("cartpole", "ps").condition_list() == check_conditions("cartpole")
    assert TuneArgs("cartpole", "ps", latency="measured").condition_list() == [Condition()]
    args = TuneArgs("cartpole", "ps", latency_ms=25.0, conditions=("latency_ms=0,50",))
    with pytest.raises(
        ConditionError,
        match="give the latency either in --conditions latency_ms=... or by --latency-ms",
    ):
        args.condition_list()


def test_the_table_names_a_condition_by_its_units():
    from judo.tuning.report import short_label

    assert short_label("control_freq=20 latency_ms=25") == "20 Hz 25 ms"
    assert short_label("latency_ms=0") == "0 ms" and short_label("default") == "default"
