"""Splines against analytic values: each order reproduces the functions it should, exactly."""

import numpy as np
import pytest

from judo import ConfigError, Spline, SplineBasis
from judo.core.spline import MIN_KNOTS, clip_ufunc

KNOT_TIMES = np.array([0.0, 0.3, 0.5, 0.9, 1.4])
QUERIES = np.linspace(0.0, 1.4, 57)


def test_zero_order_holds_each_knot_until_the_next():
    knots = np.array([[1.0], [2.0], [3.0], [4.0], [5.0]])
    values = (
        SplineBasis(KNOT_TIMES, "zero").weights(np.array([0.0, 0.29, 0.3, 0.89, 1.0, 1.4])) @ knots
    )
    np.testing.assert_array_equal(values[:, 0], [1.0, 1.0, 2.0, 3.0, 4.0, 5.0])


def test_linear_reproduces_a_line_and_interpolates_between_knots():
    line = lambda t: 2.0 - 3.0 * t  # noqa: E731
    values = SplineBasis(KNOT_TIMES, "linear").weights(QUERIES) @ line(KNOT_TIMES)
    np.testing.assert_allclose(values, line(QUERIES), atol=1e-12)
    midpoint = SplineBasis(np.array([0.0, 1.0]), "linear").weights(np.array([0.25])) @ np.array(
        [0.0, 4.0]
    )
    assert midpoint[0] == pytest.approx(1.0)


@pytest.mark.parametrize("num_knots", [4, 5, 7])
def test_cubic_reproduces_any_cubic_polynomial(num_knots):
    times = np.sort(np.r_[0.0, np.random.default_rng(num_knots).uniform(0.1, 2.0, num_knots - 1)])
    cubic = lambda t: 1.0 - 2.0 * t + 0.5 * t**2 - 0.7 * t**3  # noqa: E731
    queries = np.linspace(times[0], times[-1], 101)
    values = SplineBasis(times, "cubic").weights(queries) @ cubic(times)
    np.testing.assert_allclose(values, cubic(queries), atol=1e-10)


def test_cubic_passes_through_its_knots_and_matches_a_sine_closely():
    times = np.linspace(0.0, np.pi, 9)
    basis = SplineBasis(times, "cubic")
    np.testing.assert_allclose(basis.weights(times) @ np.sin(times), np.sin(times), atol=1e-12)
    queries = np.linspace(0.0, np.pi, 200)
    assert np.max(np.abs(basis.weights(queries) @ np.sin(times) - np.sin(queries))) < 2e-3


def test_queries_outside_the_knots_hold_the_end_values():
    spline = Spline(
        10.0,
        SplineBasis(np.array([0.0, 1.0, 2.0, 3.0]), "cubic"),
        np.array([[1.0], [5.0], [-2.0], [7.0]]),
    )
    np.testing.assert_allclose(spline(np.array([9.0, 13.0, 20.0])), [[1.0], [7.0], [7.0]])
    assert spline(11.0).shape == (1,)
    np.testing.assert_allclose(spline.knot_times, [10.0, 11.0, 12.0, 13.0])


def test_too_few_knots_for_the_order_is_a_clear_error():
    with pytest.raises(ConfigError, match="a cubic spline needs at least 4 knots, got 3"):
        SplineBasis(np.array([0.0, 0.5, 1.0]), "cubic")
    with pytest.raises(ConfigError, match="spline order must be one of"):
        SplineBasis(np.array([0.0, 1.0]), "quintic")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("order", "num_knots"),
    [(order, n) for order in MIN_KNOTS for n in (1, 2, 4, 6) if n >= MIN_KNOTS[order]],
)
def test_one_time_weights_equal_the_batched_weights(order, num_knots):
    knot_times = np.cumsum(np.random.default_rng(num_knots).uniform(0.1, 0.5, num_knots))
    basis = SplineBasis(knot_times, order)
    queries = np.concatenate(
        [[knot_times[0] - 1.0, knot_times[-1] + 1.0], knot_times, np.linspace(0, 3, 41)]
    )
    batched = basis.weights(queries)
    for query, row in zip(queries, batched, strict=True):
        np.testing.assert_allclose(basis.weights_at(query), row, atol=1e-12)
    spline = Spline(0.5, basis, np.random.default_rng(0).normal(size=(num_knots, 2)))
    np.testing.assert_allclose(spline(0.9), spline(np.array([0.9]))[0], atol=1e-12)


def plain_weights(basis: SplineBasis, query_times: np.ndarray) -> np.ndarray:
    """`SplineBasis.weights` as first written: every segment's length and factor looked up per
    query."""
    knot_times = basis.knot_times
    t = np.minimum(np.maximum(np.asarray(query_times, dtype=float), knot_times[0]), knot_times[-1])
    num_nodes, rows = len(knot_times), np.arange(len(t))
    weights = np.zeros((len(t), num_nodes))
    if num_nodes == 1:
        weights[:, 0] = 1.0
        return weights
    segment = np.clip(np.searchsorted(knot_times, t, side="right") - 1, 0, num_nodes - 2)
    if basis.order == "zero":
        weights[rows, np.where(t >= knot_times[-1], num_nodes - 1, segment)] = 1.0
        return weights
    h = knot_times[segment + 1] - knot_times[segment]
    a = (t - knot_times[segment]) / h
    weights[rows, segment] = 1.0 - a
    weights[rows, segment + 1] += a
    if basis.order == "cubic":
        b, curvature, m = 1.0 - a, h**2 / 6.0, basis._second_derivative_map
        weights += (curvature * (b**3 - b))[:, None] * m[segment] + (curvature * (a**3 - a))[
            :, None
        ] * m[segment + 1]
    return weights


@pytest.mark.parametrize("order", list(MIN_KNOTS))
def test_weights_equal_the_plain_formula_bit_for_bit(order):
    rng = np.random.default_rng(7)
    for num_knots in range(MIN_KNOTS[order], 9):
        for knot_times in (
            np.linspace(0.0, 0.25, num_knots),
            np.cumsum(rng.uniform(0.01, 1.0, num_knots)) - 0.5,
        ):
            basis = SplineBasis(knot_times, order)
            ends = [knot_times[0] - 1.0, knot_times[-1] + 1.0, np.nan, np.inf, -np.inf]
            for queries in (
                knot_times + 0.02,
                rng.uniform(-1.0, 3.0, 37),
                np.concatenate([knot_times, ends]),
            ):
                assert basis.weights(queries).tobytes() == plain_weights(basis, queries).tobytes()


def test_clip_ufunc_is_np_clip_bit_for_bit_with_signed_zeros_nan_and_inf():
    values = np.array([[-0.0, 0.0, np.nan, -np.inf, np.inf, 0.3, -2.0, 5.0]] * 3).T.copy()  # (8, 3)
    low, high = np.array([0.0, -0.0, -1.0]), np.array([1.0, 0.0, np.inf])
    assert clip_ufunc(values, low, high).tobytes() == np.clip(values, low, high).tobytes()
    out = values.copy()
    clip_ufunc(out, low, high, out=out)
    assert out.tobytes() == np.clip(values, low, high).tobytes()


def test_last_weights_are_the_weights_of_these_times_and_read_only():
    basis = SplineBasis(np.linspace(0.0, 1.0, 4), "cubic")
    shifted = np.linspace(0.0, 1.0, 4) + 0.02
    first = basis.last_weights(shifted)
    assert first.tobytes() == basis.weights(shifted).tobytes()
    assert basis.last_weights(shifted.copy()) is first  # the same times again: kept
    assert not first.flags.writeable
    other = shifted + np.array([0.0, 0.0, 0.0, 1e-12])  # one time a hair later: computed afresh
    assert basis.last_weights(other).tobytes() == basis.weights(other).tobytes()
    assert basis.last_weights(shifted[:3]).shape == (3, 4)
    spline = Spline(
        0.5, basis, np.random.default_rng(3).normal(size=(4, 2)), -np.ones(2), np.ones(2)
    )
    times = 0.5 + shifted
    expected = np.minimum(np.maximum(basis.weights(times - 0.5) @ spline.knots, -1.0), 1.0)
    assert spline(times).tobytes() == spline(times).tobytes() == expected.tobytes()
