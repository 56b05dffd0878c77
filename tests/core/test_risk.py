"""Risk measures against hand-computed values; NaN counts as -inf."""

import numpy as np
import pytest

from judo.core.errors import UnknownNameError
from judo.core.rollouts.risk import reduce_rewards

REWARDS = np.array([[1.0, 2.0, 3.0, 6.0], [-4.0, 0.0, 0.0, 0.0]])  # (num_rollouts=2, R=4)


@pytest.mark.parametrize(
    ("measure", "expected"),
    [
        ("average", [3.0, -1.0]),
        ("worst", [1.0, -4.0]),
        ("best", [6.0, 0.0]),
    ],
)
def test_average_worst_and_best(measure, expected):
    np.testing.assert_array_equal(reduce_rewards(REWARDS, measure), expected)


@pytest.mark.parametrize(
    ("alpha", "expected"),
    [
        (0.25, [1.0, -4.0]),  # ceil(0.25 * 4) = 1: the worst
        (0.5, [1.5, -2.0]),  # the worst 2: (1 + 2) / 2, (-4 + 0) / 2
        (0.6, [2.0, -4.0 / 3.0]),  # ceil(2.4) = 3
        (1.0, [3.0, -1.0]),  # all: the average
    ],
)
def test_cvar_averages_the_worst_alpha_fraction(alpha, expected):
    np.testing.assert_allclose(
        reduce_rewards(REWARDS, "cvar", cvar_alpha=alpha), expected, rtol=0, atol=1e-15
    )


def test_exponential_is_the_certainty_equivalent():
    rewards = np.array([[0.0, np.log(3.0)]])
    # scale 1: -log(mean(exp(-r))) = -log((1 + 1/3) / 2) = log(1.5)
    np.testing.assert_allclose(
        reduce_rewards(rewards, "exponential", risk_scale=1.0), [np.log(1.5)], rtol=1e-14
    )
    # scale -1 (risk-seeking): log(mean(exp(r))) = log((1 + 3) / 2) = log(2)
    np.testing.assert_allclose(
        reduce_rewards(rewards, "exponential", risk_scale=-1.0), [np.log(2.0)], rtol=1e-14
    )


def test_exponential_tends_to_worst_and_best_without_overflow():
    np.testing.assert_allclose(
        reduce_rewards(REWARDS, "exponential", risk_scale=1e4), [1.0, -4.0], atol=1e-3
    )
    np.testing.assert_allclose(
        reduce_rewards(REWARDS, "exponential", risk_scale=-1e4), [6.0, 0.0], atol=1e-3
    )
    np.testing.assert_allclose(
        reduce_rewards(REWARDS, "exponential", risk_scale=1e-6), [3.0, -1.0], atol=1e-5
    )


def test_nan_counts_as_minus_infinity_before_reduction():
    rewards = np.array([[1.0, np.nan, 3.0], [np.nan, np.nan, np.nan]])
    for measure in ("average", "worst", "cvar"):
        assert reduce_rewards(rewards, measure).tolist() == [-np.inf, -np.inf]
    assert reduce_rewards(rewards, "exponential", risk_scale=2.0).tolist() == [-np.inf, -np.inf]
    assert reduce_rewards(rewards, "best").tolist() == [3.0, -np.inf]
    assert not np.isnan(rewards[0, 0])  # the input is left alone


def test_unknown_measure_lists_the_valid_ones():
    with pytest.raises(
        UnknownNameError,
        match="unknown risk measure 'mean'; valid risk measures are: average, best",
    ):
        reduce_rewards(REWARDS, "mean")
