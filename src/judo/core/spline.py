"""Splines through control knots, as linear maps from knot values to interpolated values (numpy
only).

Every supported spline is linear in its knot values, so interpolating many knot sets at the same
query times is one matrix product: `values = weights(query_times) @ knots`. The controller
precomputes the (T, num_nodes) weights once per configuration and reuses them every update.
"""

import math
from bisect import bisect_right
from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.errors import ConfigError


def _numpy_clip_ufunc() -> np.ufunc:
    """The ufunc np.clip calls for float arrays: the same values bit for bit, without the three
    Python layers in front of it, which cost more than clipping a plan's few knots."""
    try:
        from numpy._core import umath
    except ImportError:  # numpy 1
        from numpy.core import umath
    return umath.clip  # pyright: ignore[reportAttributeAccessIssue]


clip_ufunc: np.ufunc = _numpy_clip_ufunc()
"""`clip_ufunc(values, low, high[, out=])`: np.clip(values, low, high[, out=]) for float arrays and
bounds."""

SplineOrder = Literal["zero", "linear", "cubic"]
MIN_KNOTS = {"zero": 1, "linear": 2, "cubic": 4}


class SplineBasis:
    """Interpolation weights for splines through knots at fixed `knot_times` (num_nodes,).

    Orders: "zero" holds each knot until the next one; "linear" joins knots with straight lines;
    "cubic" is the C2 cubic spline with not-a-knot ends (with 4 knots, the cubic polynomial through
    them). Query times outside the knots are clamped: the spline holds its end values.
    """

    def __init__(self, knot_times: np.ndarray, order: SplineOrder) -> None:
        knot_times = np.asarray(knot_times, dtype=float)
        if order not in MIN_KNOTS:
            raise ConfigError(f"spline order must be one of {list(MIN_KNOTS)}, got {order!r}")
        if len(knot_times) < MIN_KNOTS[order]:
            raise ConfigError(
                f"a {order} spline needs at least {MIN_KNOTS[order]} knots, got {len(knot_times)}"
            )
        if np.any(np.diff(knot_times) <= 0):
            raise ConfigError(f"knot times must increase strictly, got {knot_times}")
        self.knot_times = knot_times
        self.order: SplineOrder = order
        self._knot_list = knot_times.tolist()
        # see `last_weights`
        self._last_query: tuple[tuple[tuple[int, ...], bytes], np.ndarray] | None = None
        # What `weights` looks up per segment, computed once: the interior knots (searching them
        # gives the segment, already within 0..num_nodes - 2), each segment's length h and its cubic
        # factor h**2 / 6.
        self._interior = knot_times[1:-1]
        self._lengths = np.diff(knot_times)
        if order == "cubic":
            self._second_derivative_map = _not_a_knot_second_derivatives(knot_times)
            self._curvatures = self._lengths**2 / 6.0

    def weights(self, query_times: np.ndarray) -> np.ndarray:
        """(num_queries, num_nodes) matrix W with spline(query_times) = W @ knots."""
        t = np.minimum(
            np.maximum(np.asarray(query_times, dtype=float), self.knot_times[0]),
            self.knot_times[-1],
        )
        num_nodes = len(self.knot_times)
        rows = np.arange(len(t))
        weights = np.zeros((len(t), num_nodes))
        if num_nodes == 1:
            weights[:, 0] = 1.0
            return weights
        segment = np.searchsorted(self._interior, t, side="right")  # within 0..num_nodes - 2
        if self.order == "zero":
            at_end = t >= self.knot_times[-1]
            weights[rows, np.where(at_end, num_nodes - 1, segment)] = 1.0
            return weights
        following = segment + 1
        # position within the segment, 0..1
        a = (t - self.knot_times[segment]) / self._lengths[segment]
        b = 1.0 - a
        weights[rows, segment] = b
        weights[rows, following] += a
        if self.order == "cubic":
            curvature = self._curvatures[segment]
            m = self._second_derivative_map
            weights += (curvature * (b**3 - b))[:, None] * m[segment] + (curvature * (a**3 - a))[
                :, None
            ] * m[following]
        return weights

    def last_weights(self, query_times: np.ndarray) -> np.ndarray:
        """`weights` of the (num_queries,) float `query_times`, read-only, kept for the times of the
        last call: a plan shifted by one control period is asked for the same times bit for bit
        update after update. Thread safe: the times and their weights are kept as one pair."""
        query_times = np.asarray(query_times, dtype=float)
        key = (query_times.shape, query_times.tobytes())
        last = self._last_query
        if last is not None and last[0] == key:
            return last[1]
        weights = self.weights(query_times)
        weights.flags.writeable = False
        self._last_query = (key, weights)
        return weights

    def weights_at(self, query_time: float) -> np.ndarray:
        """(num_nodes,) row w with spline(query_time) = w @ knots: `weights` for one time, about ten
        times faster, for serving a plan at every simulation step."""
        knots = self._knot_list
        num_nodes = len(knots)
        t = min(max(float(query_time), knots[0]), knots[-1])
        weights = np.zeros(num_nodes)
        if num_nodes == 1:
            weights[0] = 1.0
            return weights
        segment = min(max(bisect_right(knots, t) - 1, 0), num_nodes - 2)
        if self.order == "zero":
            weights[num_nodes - 1 if t >= knots[-1] else segment] = 1.0
            return weights
        h = knots[segment + 1] - knots[segment]
        a = (t - knots[segment]) / h
        weights[segment] = 1.0 - a
        weights[segment + 1] += a
        if self.order == "cubic":
            b = 1.0 - a
            curvature = h * h / 6.0
            m = self._second_derivative_map
            weights += curvature * (b**3 - b) * m[segment] + curvature * (a**3 - a) * m[segment + 1]
        return weights


class Spline:
    """A control trajectory: knots (num_nodes, nu) placed at `start_time + basis.knot_times`.

    With `low` and `high` ((nu,) bounds, e.g. the actuators' ctrlrange), every value it returns is
    clamped into [low, high]: a cubic through knots that lie within the bounds can still overshoot
    them between knots, and a plant must never be commanded beyond its range.

    A planner's `update_action` sets what its update scored on the plan it returns, for the loop's
    records:
    `rewards` (num_rollouts,) and `traces` (1 + num_shown, T, num_trace_sensors, 3), the planner's
    own
    (`PlannerView`); empty where nothing was scored or rolled out.
    """

    rewards: np.ndarray = np.zeros(0)
    traces: np.ndarray = np.zeros((0, 0, 0, 3))

    def __init__(
        self,
        start_time: float,
        basis: SplineBasis,
        knots: np.ndarray,
        low: np.ndarray | None = None,
        high: np.ndarray | None = None,
    ) -> None:
        self.start_time = start_time
        self.basis = basis
        self.knots = np.array(knots, dtype=float)
        nu = self.knots.shape[-1]
        self.low = _bounds(low, -np.inf, nu)
        self.high = _bounds(high, np.inf, nu)
        # Zero-order and linear splines never leave the range of their knots, so only a cubic, or
        # knots beyond the bounds, need clamping: the common linear case pays nothing.
        has_bounds = any(map(math.isfinite, self.low.tolist())) or any(
            map(math.isfinite, self.high.tolist())
        )
        self._bounded = has_bounds and (basis.order == "cubic" or not self._knots_inside())

    @property
    def knot_times(self) -> np.ndarray:
        """(num_nodes,) absolute knot times."""
        return self.start_time + self.basis.knot_times

    def __call__(self, times: float | np.ndarray, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) for a scalar time, (num_times, nu) for an array of times, within [low, high]. The
        plant's `state` is for plans with feedback (judo.core.feedback_plan.FeedbackPlan); a plain
        spline ignores it."""
        if np.ndim(times) == 0:
            values = self.basis.weights_at(float(times) - self.start_time) @ self.knots
        else:
            values = self.basis.last_weights(np.asarray(times) - self.start_time) @ self.knots
        if self._bounded:
            # faster than np.clip or out=
            return np.minimum(np.maximum(values, self.low), self.high)
        return values

    def _knots_inside(self) -> bool:
        return bool(((self.knots >= self.low) & (self.knots <= self.high)).all())


@dataclass
class CycleLayout:
    """The arrays a planning cycle fills, sized by its horizon, knots and rollouts; the controller
    builds a new one only when one of those sizes changes.

    Attributes:
        knot_offsets: (num_nodes,) knot times from the cycle's start, evenly over the horizon.
        basis: the SplineBasis through those knots.
        rollout_weights: (T, num_nodes) weights that interpolate knots at the T rollout steps.
        controls: (N, T, nu) every rollout's controls.
        batch_controls: (R * N, T, nu) what the backend rolls out: block r is every sequence again,
            on model r; with R = 1, `controls` itself.
        control_blocks: (R, N, T, nu) `batch_controls` by model.
        trace_rows: (N + 1,) rows of the shown traces: 0 (the nominal), then the best rollouts.
    """

    knot_offsets: np.ndarray
    basis: SplineBasis
    rollout_weights: np.ndarray
    controls: np.ndarray
    batch_controls: np.ndarray
    control_blocks: np.ndarray
    trace_rows: np.ndarray

    @classmethod
    def build(
        cls,
        horizon: float,
        order: SplineOrder,
        dt: float,
        num_steps: int,
        sizes: tuple[int, int, int, int],
    ) -> "CycleLayout":
        """The layout of a cycle of `num_steps` rollout steps of `dt` s, with `order` splines
        through knots spread over `horizon` s; `sizes` = (R models, N rollouts, num_nodes knots,
        nu).

        Raises ConfigError (naming what to lower) when the arrays do not fit in memory."""
        num_models, num_rollouts, num_nodes, nu = sizes
        try:
            knot_offsets = np.linspace(0.0, horizon, num_nodes)
            basis = SplineBasis(knot_offsets, order)
            rollout_weights = basis.weights(np.arange(num_steps) * dt)
            controls = np.zeros((num_rollouts, num_steps, nu))
            batch_controls = (
                controls
                if num_models == 1
                else np.zeros((num_models * num_rollouts, *controls.shape[1:]))
            )
        except MemoryError:
            raise ConfigError(
                f"not enough memory for {num_models} x {num_rollouts} rollouts of "
                f"{num_steps} steps with "
                f"{num_nodes} knots; lower num_randomizations, num_rollouts, num_nodes or "
                "the horizon"
            ) from None
        control_blocks = batch_controls.reshape(num_models, *controls.shape)
        trace_rows = np.zeros(num_rollouts + 1, dtype=int)
        return cls(
            knot_offsets,
            basis,
            rollout_weights,
            controls,
            batch_controls,
            control_blocks,
            trace_rows,
        )


def _bounds(value: np.ndarray | None, default: float, nu: int) -> np.ndarray:
    """(nu,) float copy of `value` broadcast to nu entries, or `default` everywhere for None. The
    (nu,) array of every plan skips the broadcast, which costs more than the rest of a policy's plan
    (judo.core.policies.policy_controller)."""
    if value is None:
        return np.full(nu, default)
    array = np.asarray(value, dtype=float)
    return array.copy() if array.shape == (nu,) else np.array(np.broadcast_to(array, (nu,)))


def _not_a_knot_second_derivatives(x: np.ndarray) -> np.ndarray:
    """(n, n) matrix M with spline''(x) = M @ y for the not-a-knot cubic spline through (x, y).

    Interior rows are the usual C2 conditions; the first and last rows make the third derivative
    continuous across the second and second-to-last knots.
    """
    n = len(x)
    h = np.diff(x)
    lhs = np.zeros((n, n))
    rhs = np.zeros((n, n))
    for i in range(1, n - 1):
        lhs[i, i - 1 : i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        rhs[i, i - 1 : i + 2] = 6 / h[i - 1], -6 / h[i - 1] - 6 / h[i], 6 / h[i]
    lhs[0, :3] = h[1], -(h[0] + h[1]), h[0]
    lhs[-1, -3:] = h[-1], -(h[-2] + h[-1]), h[-2]
    return np.linalg.solve(lhs, rhs)
