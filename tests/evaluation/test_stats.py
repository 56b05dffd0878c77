import math

import numpy as np
import pytest

from judo.evaluation.stats import summarize, t_quantile


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
