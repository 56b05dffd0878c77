"""Carry per-knot optimizer state (stds, elites, evolution paths) from one plan's knot times to the
next's."""

import numpy as np


def knot_shift_matrix(old_times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """(num_new, num_old) matrix M with `M @ values` the piecewise-linear interpolation of per-knot
    `values` (num_old, ...) from `old_times` to `new_times`, held constant past either end.

    It handles a shift in time and a change of knot count alike, so state carried between planning
    cycles survives num_nodes edits. Every row is non-negative and sums to 1 (a convex combination),
    so interpolated variances stay positive and interpolated knots stay within the actuator limits.
    """
    old_times = np.asarray(old_times, dtype=float)
    new_times = np.asarray(new_times, dtype=float)
    identity = np.eye(len(old_times))
    return np.stack([np.interp(new_times, old_times, column) for column in identity], axis=1)


def shift_knots(values: np.ndarray, old_times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Per-knot `values` (..., num_old, nu) re-sampled at `new_times`: (..., num_new, nu)."""
    return knot_shift_matrix(old_times, new_times) @ values
