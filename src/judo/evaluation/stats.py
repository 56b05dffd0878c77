"""Summary statistics over seeds: the mean with a 95% confidence interval from Student's t
distribution."""

import math
from dataclasses import dataclass

import numpy as np


def t_quantile(probability: float, df: int) -> float:
    """The `probability` quantile (0.5 < probability < 1) of Student's t distribution with `df`
    degrees of freedom.

    Integrates the density with Simpson's rule and bisects on the upper limit; accurate to about
    1e-6.
    """
    assert 0.5 < probability < 1 and df >= 1
    log_scale = math.lgamma((df + 1) / 2) - math.lgamma(df / 2) - 0.5 * math.log(df * math.pi)

    def cdf(x: float) -> float:
        grid = np.linspace(0.0, x, 4001)
        density = np.exp(log_scale - (df + 1) / 2 * np.log1p(grid**2 / df))
        step = x / (len(grid) - 1)
        integral = (
            step
            / 3
            * (density[0] + density[-1] + 4 * density[1:-1:2].sum() + 2 * density[2:-1:2].sum())
        )
        return 0.5 + integral

    low, high = 0.0, 1.0
    while cdf(high) < probability:
        low, high = high, 2 * high
    for _ in range(60):
        middle = (low + high) / 2
        low, high = (middle, high) if cdf(middle) < probability else (low, middle)
    return (low + high) / 2


@dataclass
class Summary:
    """One metric over n episodes.

    Attributes:
        mean: the mean over episodes.
        ci95: half-width of the 95% confidence interval of the mean (t distribution, n - 1 degrees
            of freedom); NaN for a single episode.
        min, max: the extremes over episodes.
        n: number of episodes.
    """

    mean: float
    ci95: float
    min: float
    max: float
    n: int


def summarize(values: np.ndarray) -> Summary:
    """Summary of a metric's (n,) values over episodes (n >= 1)."""
    values = np.asarray(values, dtype=float)
    n = len(values)
    ci95 = math.nan
    if n > 1:
        ci95 = t_quantile(0.975, n - 1) * float(values.std(ddof=1)) / math.sqrt(n)
    return Summary(float(values.mean()), ci95, float(values.min()), float(values.max()), n)


def shown_interval(summary: Summary) -> str:
    """ "mean ± ci95" for a table, with "n too small" in place of an interval that says nothing: one
    from a single episode, or one wider than [0, 1] for a metric whose every value lies in [0, 1] (a
    fraction, a success, a share), which a sample that small cannot bound."""
    mean = f"{summary.mean:.3g}"
    if math.isnan(summary.ci95):
        return f"{mean} (n = {summary.n}: no interval)"
    fraction_like = 0.0 <= summary.min and summary.max <= 1.0
    if fraction_like and (summary.mean - summary.ci95 < 0.0 and summary.mean + summary.ci95 > 1.0):
        return f"{mean} (n = {summary.n} too small: the interval spans all of 0-1)"
    return f"{mean} ± {summary.ci95:.3g}"
