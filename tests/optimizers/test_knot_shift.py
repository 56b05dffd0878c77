"""Re-interpolating per-knot optimizer state to new knot times."""

import numpy as np

from judo.optimizers.knot_shift import knot_shift_matrix, shift_knots


def test_same_times_give_identity():
    times = np.array([0.0, 0.3, 0.7, 1.0])
    np.testing.assert_array_equal(knot_shift_matrix(times, times), np.eye(4))


def test_linear_values_shift_exactly_and_hold_past_the_end():
    old_times = np.linspace(0.0, 1.0, 5)
    values = np.stack([2.0 * old_times, -old_times + 1.0], axis=1)  # (5, 2), linear in time
    new_times = old_times + 0.1
    shifted = shift_knots(values, old_times, new_times)
    np.testing.assert_allclose(
        shifted[:-1], np.stack([2.0 * new_times[:-1], -new_times[:-1] + 1.0], axis=1)
    )
    np.testing.assert_allclose(shifted[-1], values[-1])  # 1.1 is past the old plan: held


def test_changing_knot_count_gives_convex_rows_and_batches():
    old_times, new_times = np.linspace(0.0, 1.0, 4), np.linspace(0.05, 1.05, 7)
    matrix = knot_shift_matrix(old_times, new_times)
    assert matrix.shape == (7, 4)
    assert (matrix >= 0).all()
    np.testing.assert_allclose(matrix.sum(axis=1), 1.0)
    batch = np.arange(3 * 4 * 2, dtype=float).reshape(3, 4, 2)
    shifted = shift_knots(batch, old_times, new_times)
    assert shifted.shape == (3, 7, 2)
    np.testing.assert_allclose(shifted[1], matrix @ batch[1])


def test_single_old_knot_is_held_everywhere():
    shifted = shift_knots(np.array([[0.5, -0.5]]), np.array([0.0]), np.array([0.0, 0.5, 1.0]))
    np.testing.assert_array_equal(shifted, np.tile([0.5, -0.5], (3, 1)))
