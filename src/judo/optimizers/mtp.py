"""Model tensor planning (MTP): globally spread samples from random paths through a multipartite
graph over the control range, smoothed into knot sequences, mixed with a local Gaussian refitted to
the elites.

A. T. Le, K. Nguyen, M. N. Vu, J. Carvalho, J. Peters, "Model Tensor Planning", Transactions on
Machine Learning Research, 2025, arXiv:2505.01059.
"""

import functools
import typing
from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig, PlanningStart, weighted_knots
from judo.optimizers.cem import check_elite_settings
from judo.optimizers.knot_shift import knot_shift_matrix
from judo.optimizers.mppi import softmax_weights

PathSmoothing = Literal["linear", "bspline"]
BSPLINE_DEGREE = 2
"""Degree of the B-spline through a tensor path's waypoints (quadratic, as the paper's default)."""
UNBOUNDED_SPAN = 3.0
"""Where a control has no finite limit, its graph spans the nominal +- this many sigma_max."""


@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 2.0, 0.001)
@slider("num_elites", 1, 128, 1)
@slider("temperature", 0.001, 10.0, 0.001)
@slider("tensor_fraction", 0.0, 1.0, 0.05)
@slider("num_waypoints", 2, 10, 1)
@slider("graph_width", 1, 128, 1)
@slider("momentum", 0.0, 0.99, 0.01)
@dataclass
class MTPConfig(OptimizerConfig):
    """MTP settings: the tensor graph and its share of the samples, and the local Gaussian's elite
    refit."""

    sigma_min: float = 0.1
    """Lower bound on the local Gaussian's per-knot std, so the local search never collapses."""
    sigma_max: float = 0.5
    """Upper bound on the local Gaussian's per-knot std, and its initial value."""
    num_elites: int = 8
    """Best samples the local Gaussian is refitted to (at most num_rollouts)."""
    temperature: float = 0.1
    """Softmax temperature on the elites' rewards: small follows the best elite, large averages
    them."""
    tensor_fraction: float = 0.2
    """Share beta of the samples (besides the plan and the best sample kept) drawn from the tensor
    graph; the rest are local Gaussian samples around the plan."""
    num_waypoints: int = 3
    """Layers M of the graph: waypoints of each tensor path over the horizon."""
    graph_width: int = 16
    """Nodes per layer: candidate controls drawn uniformly over the control range at each
    waypoint."""
    path_smoothing: PathSmoothing = "bspline"
    """How a path's waypoints become knots: piecewise-linear through them, or a clamped quadratic
    B-spline."""
    momentum: float = 0.5
    """Share of the old mean and variance kept in the refit (0: the elites' statistics alone)."""

    def validate(self) -> None:
        super().validate()
        check_elite_settings(self)
        require(self.temperature > 0, f"temperature must be positive, got {self.temperature}")
        require_between("tensor_fraction", self.tensor_fraction, 0, 1)
        require_between("num_waypoints", self.num_waypoints, 2, 100)
        require_between("graph_width", self.graph_width, 1, 10_000)
        require(
            0 <= self.momentum < 1, f"momentum must be at least 0 and below 1, got {self.momentum}"
        )
        choices = typing.get_args(PathSmoothing)
        require(
            self.path_smoothing in choices,
            f"path_smoothing must be one of {list(choices)}, got {self.path_smoothing!r}",
        )
        if self.path_smoothing == "bspline":
            require(
                self.num_waypoints > BSPLINE_DEGREE,
                "path_smoothing 'bspline' (quadratic) needs num_waypoints >= "
                f"{BSPLINE_DEGREE + 1}, got {self.num_waypoints}",
            )


class MTP(Optimizer[MTPConfig]):
    """Model tensor planning: tensor-graph samples for global exploration, a local CEM-style
    Gaussian to refine.

    Each iteration's samples are, in order: the plan (the nominal, which is also the local
    Gaussian's mean), the best sample of the last iteration, then round(tensor_fraction * rest)
    tensor samples and the rest local samples nominal + sigma * N(0, I). A tensor sample is a random
    path through an M-partite graph (M = num_waypoints layers of graph_width nodes, each node drawn
    uniformly over the control range, new every iteration): one node per layer, taken through the M
    waypoints, spread evenly over the knots, by a piecewise-linear or a clamped quadratic B-spline
    (a fixed (num_nodes, M) matrix, so the smoothing is one product; both stay within the waypoints'
    hull, so within the control range).

    The update ranks all samples, keeps the num_elites best with finite rewards, weighs them by
    softmax(rewards / temperature), and moves the Gaussian towards their weighted mean and std
    (clipped to [sigma_min, sigma_max]) with `momentum`:

        mean <- momentum * nominal + (1 - momentum) * sum_e w_e x_e                       (the new plan)
        sigma^2 <- momentum * sigma^2 + (1 - momentum) * clip(std_w(x_e), sigma_min, sigma_max)^2

    The control range comes from the task at each cycle's start (`set_start`: its actuators', or a
    low-level policy's commands'); a control without a finite limit spans the nominal +- 3
    sigma_max. Between cycles sigma and the kept best sample are shifted to the new knot times.
    Unlike the paper, Akima smoothing is not offered, and the plan is the smoothed elite mean (the
    paper's CEM update), not the best sample; with use_noise_ramp on, sigma is stored without the
    ramp, as CEM's.

    Attributes:
        sigma: (num_nodes, nu) the local Gaussian's std, before the noise ramp.
        best: (num_nodes, nu) the last iteration's best sample, or None until the first update.
        command_range: (nu, 2) the [low, high] range tensor nodes are drawn from, or None before
            `set_start`.
    """  # noqa: E501

    def __init__(self, config: MTPConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.command_range: np.ndarray | None = None
        self.restart()

    def restart(self) -> None:
        """Start wide again (sigma_max on every knot) and forget the kept best sample."""
        self.sigma = np.full((self.num_nodes, self.nu), self.config.sigma_max)
        self.best: np.ndarray | None = None

    def set_start(self, start: PlanningStart) -> None:
        self.command_range = np.asarray(start.task.command_range, dtype=float)

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if len(self.sigma) != len(old_times):  # state that does not belong to the old plan
            self.restart()
            return
        shift = knot_shift_matrix(old_times, new_times)
        self.sigma = shift @ self.sigma
        if self.best is not None:
            self.best = shift @ self.best

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        if len(self.sigma) != self.num_nodes:  # sizes changed without pre_optimization
            self.restart()
        cfg = self.config
        self._nominal = nominal_knots.copy()
        fixed = nominal_knots[None] if self.best is None else np.stack([nominal_knots, self.best])
        fixed = fixed[: self.num_rollouts]
        rest = self.num_rollouts - len(fixed)
        num_tensor = round(cfg.tensor_fraction * rest)
        local = self.rng.standard_normal((rest - num_tensor, self.num_nodes, self.nu))
        local *= self.sigma * self.noise_ramp_scale()
        local += nominal_knots
        return np.concatenate([fixed, self.tensor_samples(num_tensor, nominal_knots), local])

    def tensor_samples(self, count: int, nominal_knots: np.ndarray) -> np.ndarray:
        """(count, num_nodes, nu) knot sequences smoothed from random paths through a new random
        graph."""
        cfg = self.config
        low, high = self._graph_range(nominal_knots)
        graph = self.rng.uniform(low, high, (cfg.num_waypoints, cfg.graph_width, self.nu))
        choices = self.rng.integers(0, cfg.graph_width, (count, cfg.num_waypoints))
        paths = graph[np.arange(cfg.num_waypoints), choices]  # (count, M, nu)
        return np.matmul(path_matrix(self.num_nodes, cfg.num_waypoints, cfg.path_smoothing), paths)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        cfg = self.config
        ranked = np.argsort(-rewards, kind="stable")
        ranked = ranked[np.isfinite(rewards[ranked])][: cfg.num_elites]
        elites = sampled_knots[ranked]
        weights = softmax_weights(rewards[ranked], cfg.temperature)
        elite_mean = weighted_knots(weights, elites)
        elite_std = (
            np.sqrt(weighted_knots(weights, np.square(elites - elite_mean)))
            / self.noise_ramp_scale()
        )
        elite_std = np.clip(elite_std, cfg.sigma_min, cfg.sigma_max)
        self.sigma = np.sqrt(
            cfg.momentum * np.square(self.sigma) + (1 - cfg.momentum) * np.square(elite_std)
        )
        self.best = elites[0].copy()
        return cfg.momentum * self._nominal + (1 - cfg.momentum) * elite_mean

    def _graph_range(self, nominal_knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(nu,) low and high of the graph's nodes: the control range, or the nominal +- 3 sigma_max
        where unbounded."""
        limits = (
            self.command_range
            if self.command_range is not None and len(self.command_range) == self.nu
            else None
        )
        if limits is not None and np.isfinite(limits).all():
            return limits[:, 0], limits[:, 1]
        span = UNBOUNDED_SPAN * self.config.sigma_max
        low, high = nominal_knots.min(axis=0) - span, nominal_knots.max(axis=0) + span
        if limits is not None:
            bounded = np.isfinite(limits)
            low = np.where(bounded[:, 0], limits[:, 0], low)
            high = np.where(bounded[:, 1], limits[:, 1], high)
        return low, high


@functools.lru_cache(maxsize=32)
def path_matrix(num_nodes: int, num_waypoints: int, smoothing: str) -> np.ndarray:
    """(num_nodes, num_waypoints) matrix taking a path's waypoints to its knots: piecewise-linear
    interpolation over evenly spaced waypoints ("linear"), or a clamped uniform B-spline of degree
    BSPLINE_DEGREE with the waypoints as control points ("bspline"). Rows are non-negative and sum
    to 1. Cached and read-only."""
    times = np.linspace(0.0, 1.0, num_nodes)
    if smoothing == "linear":
        matrix = knot_shift_matrix(np.linspace(0.0, 1.0, num_waypoints), times)
    else:
        matrix = bspline_basis(times, num_waypoints, BSPLINE_DEGREE)
    matrix.flags.writeable = False
    return matrix


def bspline_basis(x: np.ndarray, num_control: int, degree: int) -> np.ndarray:
    """(len(x), num_control) B-spline basis functions of `degree` at `x` in [0, 1] on the clamped
    uniform knot vector (degree + 1 repeated knots at each end), by the Cox-de Boor recursion; the
    curve starts at the first control point and ends at the last."""
    inner = np.linspace(0.0, 1.0, num_control - degree + 1)
    knots = np.concatenate([np.zeros(degree), inner, np.ones(degree)])
    x = np.asarray(x, dtype=float)[:, None]
    basis = ((knots[:-1] <= x) & (x < knots[1:])).astype(float)
    # the right end belongs to the last non-empty interval
    basis[x[:, 0] >= 1.0, num_control - 1] = 1.0
    for p in range(1, degree + 1):
        width = len(knots) - 1 - p
        left_span = knots[p : p + width] - knots[:width]
        right_span = knots[p + 1 : p + 1 + width] - knots[1 : 1 + width]
        left = np.divide(
            x - knots[:width], left_span, out=np.zeros((len(x), width)), where=left_span > 0
        )
        right = np.divide(
            knots[p + 1 : p + 1 + width] - x,
            right_span,
            out=np.zeros((len(x), width)),
            where=right_span > 0,
        )
        basis = left * basis[:, :width] + right * basis[:, 1 : 1 + width]
    return basis[:, :num_control]
