"""Reward-shaping helpers. The norms reduce over the last axis: pass `x[..., None]` for a scalar per
step."""

import numpy as np


def quadratic_norm(x: np.ndarray) -> np.ndarray:
    """0.5 * ||x||^2 over the last axis: (..., d) -> (...)."""
    return 0.5 * np.square(x).sum(-1)


def smooth_l1_norm(x: np.ndarray, p: float) -> np.ndarray:
    """sqrt(||x||^2 + p^2) - p over the last axis: (..., d) -> (...).

    Quadratic near zero (within about p) and linear far away, so distant goals do not dominate.
    """
    return np.sqrt(np.square(x).sum(-1) + p * p) - p


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles mapped into [-pi, pi), same shape: the error to use for a joint that turns freely."""
    return np.mod(angle + np.pi, 2.0 * np.pi) - np.pi
