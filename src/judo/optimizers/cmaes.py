"""CMA-ES (Hansen 2016) with a diagonal covariance (sep-CMA-ES, Ros & Hansen 2008) over the flattened knots.

N. Hansen, "The CMA Evolution Strategy: A Tutorial", arXiv:1604.00772, 2016.
R. Ros, N. Hansen, "A Simple Modification in CMA-ES Achieving Linear Time and Space Complexity", PPSN 2008.
"""

from dataclasses import dataclass

import numpy as np

from judo.core.config import require
from judo.core.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.optimizers.knot_shift import knot_shift_matrix


@slider("sigma", 0.001, 2.0, 0.001)
@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 5.0, 0.001)
@dataclass
class CMAESConfig(OptimizerConfig):
    """CMA-ES settings; the learning rates are Hansen's defaults and are not exposed."""

    sigma: float = 0.3
    """Initial step size in control units (clipped to [sigma_min, sigma_max]); editing it restarts the search distribution."""
    sigma_min: float = 0.02
    """Lower bound on every coordinate's std step_size * sqrt(C_ii), so the search never collapses between cycles."""
    sigma_max: float = 1.0
    """Upper bound on every coordinate's std step_size * sqrt(C_ii)."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(
            0 < self.sigma_min <= self.sigma_max,
            f"need 0 < sigma_min <= sigma_max, got {self.sigma_min}, {self.sigma_max}",
        )


@dataclass(frozen=True)
class CMAESParameters:
    """Strategy parameters of one population size and dimension (Hansen 2016, Table 1 and eqs. 47-58)."""

    mu: int
    """Parents: the best mu = lambda // 2 samples enter the update."""
    weights: np.ndarray
    """(mu,) recombination weights w_i proportional to ln((lambda + 1) / 2) - ln(i), summing to 1."""
    mu_eff: float
    """Variance-effective selection mass 1 / sum(w_i^2)."""
    c_sigma: float
    """Learning rate of the step-size path."""
    d_sigma: float
    """Damping of the step-size update."""
    c_c: float
    """Learning rate of the covariance path."""
    c_1: float
    """Rank-one covariance learning rate."""
    c_mu: float
    """Rank-mu covariance learning rate."""
    chi_n: float
    """E||N(0, I_n)||, the length a path has under random selection."""


def cmaes_parameters(lam: int, n: int) -> CMAESParameters:
    """Hansen's default parameters for population `lam` in dimension `n`, with the covariance learning
    rates multiplied by (n + 2) / 3 as sep-CMA-ES prescribes for a diagonal covariance."""
    mu = max(1, lam // 2)
    raw = np.log((lam + 1) / 2) - np.log(np.arange(1, mu + 1))
    weights = raw / raw.sum() if raw.sum() > 0 else np.full(mu, 1.0 / mu)
    mu_eff = float(1.0 / np.square(weights).sum())
    c_sigma = (mu_eff + 2) / (n + mu_eff + 5)
    c_1 = 2 / ((n + 1.3) ** 2 + mu_eff)
    c_mu = min(1 - c_1, 2 * (mu_eff - 2 + 1 / mu_eff) / ((n + 2) ** 2 + mu_eff))
    diagonal_speedup = (n + 2) / 3
    c_1 = min(1.0, c_1 * diagonal_speedup)
    return CMAESParameters(
        mu=mu,
        weights=weights,
        mu_eff=mu_eff,
        c_sigma=c_sigma,
        d_sigma=1 + 2 * max(0.0, np.sqrt((mu_eff - 1) / (n + 1)) - 1) + c_sigma,
        c_c=(4 + mu_eff / n) / (n + 4 + 2 * mu_eff / n),
        c_1=c_1,
        c_mu=min(1 - c_1, c_mu * diagonal_speedup),
        chi_n=float(np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))),
    )


class CMAES(Optimizer[CMAESConfig]):
    """CMA-ES over the num_nodes * nu knot values, warm-started each cycle from the shifted nominal.

    Each iteration samples x_k = m + step_size * sqrt(C) * z_k, z_k ~ N(0, I), around the mean m, which
    is always the nominal the controller passes in: at the first iteration of a cycle that is the
    previous plan shifted to the new knot times. Sample 0 is m itself (z = 0), as every judo optimizer
    does; it is ranked like the others. The update follows Hansen's tutorial with positive weights only
    (no active CMA), c_m = 1, and the samples as the controller clamped them to the actuator limits:

        y_k = (x_k - m) / step_size,   <y> = sum_{i<=mu} w_i y_{i:lambda},   m <- m + step_size <y>
        p_sigma <- (1 - c_sigma) p_sigma + sqrt(c_sigma (2 - c_sigma) mu_eff) C^{-1/2} <y>
        p_c <- (1 - c_c) p_c + h_sigma sqrt(c_c (2 - c_c) mu_eff) <y>
        C <- (1 - c_1 - c_mu) C + c_1 (p_c^2 + delta(h_sigma) C) + c_mu sum_i w_i y_{i:lambda}^2
        step_size <- step_size exp((c_sigma / d_sigma) (|p_sigma| / E|N(0, I)| - 1))

    with lambda = num_rollouts. C is diagonal (sep-CMA-ES): a full n x n covariance needs on the order
    of n^2 / mu_eff samples to learn, far more than the few dozen rollouts of a handful of iterations per
    control cycle, while the diagonal's learning rates may be (n + 2) / 3 times larger; it also costs
    O(n) per sample, so it scales to hands with many actuators and knots. Because the MPC problem moves
    every cycle, each coordinate's std step_size * sqrt(C_ii) is kept in [sigma_min, sigma_max].

    C, p_sigma and p_c are per knot and control, so between cycles they are re-interpolated from the old
    knot times to the new ones, like the plan itself; this also carries them across a num_nodes edit.
    A num_rollouts edit only changes lambda and the parameters derived from it. use_noise_ramp shapes
    the initial C (it is the initial per-knot std profile).

    Attributes:
        step_size: the global step size sigma of CMA-ES.
        variances: (num_nodes * nu,) the diagonal of C.
        path_sigma, path_c: (num_nodes * nu,) the evolution paths.
        generation: updates since the distribution was (re)started.
    """

    def __init__(self, config: CMAESConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Reset the search distribution to step size `sigma`, C from the noise ramp, and zero paths."""
        cfg = self.config
        n = self.num_nodes * self.nu
        self._restart_sigma = cfg.sigma
        self.step_size = float(np.clip(cfg.sigma, cfg.sigma_min, cfg.sigma_max))
        self.variances = np.square(np.broadcast_to(self.noise_ramp_scale(), (self.num_nodes, self.nu))).ravel()
        self.path_sigma = np.zeros(n)
        self.path_c = np.zeros(n)
        self.generation = 0
        self._mean = np.zeros(n)
        self._clip_spread()

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if self.config.sigma != self._restart_sigma or len(self.variances) != len(old_times) * self.nu:
            self.restart()  # a new initial sigma from the GUI, or state that does not belong to the old plan
            return
        shift = knot_shift_matrix(old_times, new_times)
        for name in ("variances", "path_sigma", "path_c"):
            per_knot = getattr(self, name).reshape(len(old_times), self.nu)
            setattr(self, name, (shift @ per_knot).ravel())
        self._clip_spread()

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        if len(self.variances) != self.num_nodes * self.nu:  # sizes changed without pre_optimization
            self.restart()
        self._mean = nominal_knots.ravel().astype(float)
        noise = self.rng.standard_normal((self.num_rollouts - 1, len(self._mean)))
        samples = self._mean + self.step_size * np.sqrt(self.variances) * noise
        return np.concatenate([self._mean[None], samples]).reshape(self.num_rollouts, self.num_nodes, self.nu)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        n = len(self._mean)
        p = cmaes_parameters(self.num_rollouts, n)
        steps = (sampled_knots.reshape(self.num_rollouts, n) - self._mean) / self.step_size
        parents = np.argsort(-rewards, kind="stable")[: p.mu]
        weights = np.where(np.isfinite(rewards[parents]), p.weights[: len(parents)], 0.0)
        weights /= weights.sum()
        mean_step = weights @ steps[parents]
        new_mean = self._mean + self.step_size * mean_step

        self.generation += 1
        self.path_sigma *= 1 - p.c_sigma
        self.path_sigma += np.sqrt(p.c_sigma * (2 - p.c_sigma) * p.mu_eff) * mean_step / np.sqrt(self.variances)
        path_sigma_norm = float(np.linalg.norm(self.path_sigma))
        unbiased_norm = path_sigma_norm / np.sqrt(1 - (1 - p.c_sigma) ** (2 * self.generation))
        h_sigma = float(unbiased_norm < (1.4 + 2 / (n + 1)) * p.chi_n)
        self.path_c *= 1 - p.c_c
        self.path_c += h_sigma * np.sqrt(p.c_c * (2 - p.c_c) * p.mu_eff) * mean_step
        delta = (1 - h_sigma) * p.c_c * (2 - p.c_c)
        self.variances = (
            (1 - p.c_1 - p.c_mu) * self.variances
            + p.c_1 * (np.square(self.path_c) + delta * self.variances)
            + p.c_mu * (weights @ np.square(steps[parents]))
        )
        self.step_size *= float(np.exp(p.c_sigma / p.d_sigma * (path_sigma_norm / p.chi_n - 1)))
        self._clip_spread()
        return new_mean.reshape(self.num_nodes, self.nu)

    def _clip_spread(self) -> None:
        """Keep step_size and every coordinate's std step_size * sqrt(C_ii) within [sigma_min, sigma_max]."""
        cfg = self.config
        self.step_size = float(np.clip(self.step_size, cfg.sigma_min, cfg.sigma_max))
        low, high = (cfg.sigma_min / self.step_size) ** 2, (cfg.sigma_max / self.step_size) ** 2
        np.clip(self.variances, low, high, out=self.variances)
