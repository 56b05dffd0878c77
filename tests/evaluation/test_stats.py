import math

import numpy as np
import pytest

from judo.evaluation.stats import shown_interval, summarize, t_quantile


@pytest.mark.parametrize(
    ("df", "expected"),  # two-sided 95% critical values from any t table
    [(1, 12.7062), (2, 4.3027), (4, 2.7764), (9, 2.2622), (29, 2.0452), (120, 1.9799)],
)
def test_t_quantile_matches_the_t_table(df, expected):
    assert t_quantile(0.975, df) == pytest.approx(expected, abs=1e-4)


def test_summary_of_three_values_uses_the_t_interval():
    summary = summarize(np.array([1.0, 2.0, 3.0]))
    assert (summary.mean, summary.min, summary.max, summary.n) == (2.0, 1.0, 3.0, 3)
    assert summary.ci95 == pytest.approx(t_quantile(0.975, 2) * 1.0 / math.sqrt(3))


def test_summary_of_one_value_has_no_interval():
    summary = summarize(np.array([0.5]))
    assert summary.mean == 0.5 and math.isnan(summary.ci95)


def test_an_interval_that_spans_all_of_0_to_1_says_n_is_too_small_instead():
    two_seeds = summarize(np.array([0.2, 0.9]))  # half-width 12.7 * 0.35 = 4.4
    assert two_seeds.ci95 > 1 and shown_interval(two_seeds) == (
        "0.55 (n = 2 too small: the interval spans all of 0-1)"
    )
    assert shown_interval(summarize(np.array([0.5]))) == "0.5 (n = 1: no interval)"
    narrow = summarize(np.array([0.5, 0.52, 0.54]))
    assert shown_interval(narrow) == f"0.52 ± {narrow.ci95:.3g}"
    # a reward: its interval is shown whatever its width
    unbounded = summarize(np.array([-3.0, 5.0]))
    assert shown_interval(unbounded) == f"1 ± {unbounded.ci95:.3g}"
