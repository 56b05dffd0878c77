"""DIAL-MPC (Xue et al. 2024): MPPI whose sampling noise is annealed along the horizon and across
iterations.

H. Xue, C. Pan, Z. Yi, G. Qu, G. Shi, "Full-Order Sampling-Based MPC for Torque-Level Locomotion
Control via Diffusion-Style Annealing", arXiv:2409.15610, 2024.
"""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.controller_config import MAX_OPT_ITERS
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig, weighted_knots


@slider("sigma", 0.001, 2.0, 0.001)
@slider("beta_opt_iter", 0.05, 5.0, 0.05)
@slider("beta_horizon", 0.05, 5.0, 0.05)
@slider("temperature", 0.01, 5.0, 0.01)
@slider("anneal_iters", 1, 20, 1)
@dataclass
class DialConfig(OptimizerConfig):
    """DIAL-MPC settings: the noise level, the two annealing rates, and the softmax temperature."""

    sigma: float = 0.3
    """Noise std at the first iteration and the last knot (the largest noise), in control units."""
    beta_opt_iter: float = 1.0
    """Iteration annealing rate beta_1: the last of N iterations samples with about exp(-1/beta_1)
    of the first one's noise; larger anneals less."""
    beta_horizon: float = 2.0
    """Horizon annealing rate beta_2: the first knot gets about exp(-1/beta_2) of the last knot's
    noise; larger anneals less."""
    temperature: float = 0.01
    """Softmax temperature on standardised rewards (r - mean) / std: small follows the best sample,
    large averages them (raise it with num_rollouts)."""
    anneal_iters: int = 4
    """Annealing iterations N per planning cycle; the cycle ends after N of them (so it runs min(N,
    max_opt_iters))."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(self.beta_opt_iter > 0, f"beta_opt_iter must be positive, got {self.beta_opt_iter}")
        require(self.beta_horizon > 0, f"beta_horizon must be positive, got {self.beta_horizon}")
        require(self.temperature > 0, f"temperature must be positive, got {self.temperature}")
        require_between("anneal_iters", self.anneal_iters, 1, MAX_OPT_ITERS)


class Dial(Optimizer[DialConfig]):
    """MPPI with DIAL-MPC's two-level ("diffusion-style") annealing of the sampling noise.

    The paper anneals the covariance at diffusion step i (counting down from N to 1) and horizon
    step h
    (of H) as  Sigma_h^i = exp(-(N - i) / (beta_1 N) - (H - h) / (beta_2 H)) I.  Counting iterations up
    instead, with k = N - i in {0, ..., N-1} the iteration within this planning cycle and h in
    {0, ..., H-1} the knot (H = num_nodes), the noise std of knot h at iteration k is

        sigma_{k,h} = sigma * exp(-k / (beta_opt_iter * N) - (H - 1 - h) / (beta_horizon * H)),

    so the first iteration samples widest and each later one narrower (coarse-to-fine, like a
    diffusion model's reverse process), and knots further out, whose effect is least certain, get
    more noise than the near ones. As in the authors' reference code the factor scales the noise std
    (their constant per-iteration and per-knot ratios are this same exponential schedule). The
    update is MPPI's: the new nominal is sum_j w_j knots_j with w = softmax(standardised rewards /
    temperature); standardising (as the reference code does) makes one temperature work across
    reward scales. Between cycles the plan is warm-started by the controller's shift, as in the
    paper.

    Judo's controller runs at most `max_opt_iters` iterations; this optimizer ends the cycle after
    `anneal_iters`, so set max_opt_iters >= anneal_iters to run the whole schedule. The paper's
    larger iteration count for the very first cycle is not modelled. The base noise ramp, if
    switched on, multiplies on top of the horizon schedule.

    Attributes:
        iteration: iterations done in the current planning cycle (k of the next sample).
    """  # noqa: E501

    def __init__(self, config: DialConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.iteration = 0

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        self.iteration = 0

    def noise_std(self, iteration: int) -> np.ndarray:
        """(num_nodes, 1) noise std of every knot at `iteration` (counted from 0 within the
        cycle)."""
        cfg, num_knots = self.config, self.num_nodes
        k = min(iteration, cfg.anneal_iters - 1)
        steps_from_end = num_knots - 1 - np.arange(num_knots)
        exponent = -k / (cfg.beta_opt_iter * cfg.anneal_iters) - steps_from_end / (
            cfg.beta_horizon * num_knots
        )
        return cfg.sigma * np.exp(exponent)[:, None]

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        return self.perturb(nominal_knots, self.noise_std(self.iteration))

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        self.iteration += 1
        weights = standardised_softmax_weights(rewards, self.config.temperature)
        return weighted_knots(weights, sampled_knots)

    def stop_cond(self) -> bool:
        return self.iteration >= self.config.anneal_iters


def standardised_softmax_weights(rewards: np.ndarray, temperature: float) -> np.ndarray:
    """(num_rollouts,) weights summing to 1: softmax((r - mean) / (std * temperature)) over the
    finite rewards; -inf rewards get 0, and equal rewards share the weight equally."""
    finite = np.isfinite(rewards)
    spread = rewards[finite].std()
    scaled = np.where(finite, rewards - rewards[finite].max(), -np.inf)
    if spread > 0:
        scaled /= spread * temperature
    weights = np.exp(scaled)
    return weights / weights.sum()
