"""CMA-ES (Hansen 2016) with a diagonal covariance (sep-CMA-ES, Ros & Hansen 2008) over the
flattened knots.

N. Hansen, "The CMA Evolution Strategy: A Tutorial", arXiv:1604.00772, 2016. R. Ros, N. Hansen, "A
Simple Modification in CMA-ES Achieving Linear Time and Space Complexity", PPSN 2008.
"""

import functools
from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.optimizers.knot_shift import knot_shift_matrix


@slider("num_rollouts", 2, 512, 1)  # CMA-ES needs a population besides the plan
@slider("sigma", 0.001, 2.0, 0.001)
@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 5.0, 0.001)
@dataclass
class CMAESConfig(OptimizerConfig):
    """CMA-ES settings; the learning rates are Hansen's defaults and are not exposed."""

    sigma: float = 0.3
    """Initial step size in control units (clipped to [sigma_min, sigma_max]); editing it restarts
    the search distribution."""
    sigma_min: float = 0.1
    """Lower bound on every coordinate's std step_size * sqrt(C_ii), so the search never collapses
    between cycles."""
    sigma_max: float = 0.5
    """Upper bound on every coordinate's std step_size * sqrt(C_ii)."""
    execute_best: bool = True
    """Plan with the best sample evaluated so far (on) or with CMA-ES's distribution mean (off)."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(
            self.num_rollouts >= 2,
            f"CMA-ES needs num_rollouts >= 2 (the plan plus a population), got {self.num_rollouts}",
        )
        require(
            0 < self.sigma_min <= self.sigma_max,
            f"need 0 < sigma_min <= sigma_max, got {self.sigma_min}, {self.sigma_max}",
        )


@dataclass(frozen=True)
class CMAESParameters:
    """Strategy parameters of one population size and dimension (Hansen 2016, Table 1 and
    eqs. 47-58)."""

    mu: int
    """Parents: the best mu = lambda // 2 samples enter the update."""
    weights: np.ndarray
    """(mu,) recombination weights w_i proportional to ln((lambda + 1) / 2) - ln(i), summing to
    1."""
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


@functools.lru_cache(maxsize=16)
def cmaes_parameters(lam: int, n: int) -> CMAESParameters:
    """Hansen's default parameters for population `lam` in dimension `n`, with the covariance
    learning rates multiplied by (n + 2) / 3 as sep-CMA-ES prescribes for a diagonal covariance.
    Cached: the sizes change only when num_rollouts or num_nodes is edited."""
    mu = max(1, lam // 2)
    raw = np.log((lam + 1) / 2) - np.log(np.arange(1, mu + 1))
    weights = raw / raw.sum() if raw.sum() > 0 else np.full(mu, 1.0 / mu)
    weights.flags.writeable = False  # shared through the cache
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
    """CMA-ES over the num_nodes * nu knot values, its mean warm-started each cycle from the shifted
    plan.

    Each iteration evaluates the plan (sample 0, the nominal passed in) and a population of lambda =
    num_rollouts - 1 samples x_k = m + step_size * sqrt(C) z_k, z_k ~ N(0, I). At the first
    iteration of a cycle the mean m is the nominal, i.e. the previous plan shifted to the new knot
    times. The update is Hansen's tutorial's with positive weights only (no active CMA) and c_m = 1,
    on the population ranked by reward:

        y_k = sqrt(C) z_k,   <y> = sum_{i<=mu} w_i y_{i:lambda},   m <- m + step_size <y>
        p_sigma <- (1 - c_sigma) p_sigma + sqrt(c_sigma (2 - c_sigma) mu_eff) C^{-1/2} <y>
        p_c <- (1 - c_c) p_c + h_sigma sqrt(c_c (2 - c_c) mu_eff) <y>
        C <- (1 - c_1 - c_mu) C + c_1 (p_c^2 + delta(h_sigma) C) + c_mu sum_i w_i y_{i:lambda}^2
        step_size <- step_size exp((c_sigma / d_sigma) (|p_sigma| / E|N(0, I)| - 1))

    The steps y are the ones drawn; the controller evaluates them clamped to the actuator limits,
    and updating with the clamped steps would shrink C wherever the plan saturates. The new plan is
    the best sample evaluated this iteration (`execute_best`, the default: rollouts are
    deterministic, so the plan never gets worse within a cycle) or the new mean m.

    C is diagonal (sep-CMA-ES): a full n x n covariance needs on the order of n^2 / mu_eff samples
    to learn, far more than the few dozen rollouts of a handful of iterations per control cycle,
    while the diagonal's learning rates may be (n + 2) / 3 times larger; it also costs O(n) per
    sample, so it scales to hands with many actuators and knots. After each update C is rescaled to
    mean(C_ii) = 1 and its scale moved into step_size (step_size^2 C is unchanged), so step_size is
    the RMS std; then step_size and every coordinate's std step_size * sqrt(C_ii) are clipped to
    [sigma_min, sigma_max], because the MPC problem moves every cycle and a collapsed search could
    not follow it.

    C, p_sigma and p_c are per knot and control, so between cycles they are re-interpolated from the
    old knot times to the new ones, like the plan itself; this also carries them across a num_nodes
    edit. A num_rollouts edit only changes lambda and the parameters derived from it. Editing
    `sigma` restarts the distribution. use_noise_ramp shapes the initial C (the initial per-knot std
    profile).

    Attributes:
        mean: (num_nodes * nu,) the distribution mean m.
        step_size: the global step size sigma of CMA-ES (the RMS std of the samples).
        variances: (num_nodes * nu,) the diagonal of C, with mean 1.
        path_sigma, path_c: (num_nodes * nu,) the evolution paths.
        generation: updates since the distribution was (re)started.
    """

    def __init__(self, config: CMAESConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Reset the search distribution to step size `sigma`, C from the noise ramp, and zero
        paths."""
        cfg = self.config
        n = self.num_nodes * self.nu
        self._restart_sigma = cfg.sigma
        self.step_size = float(np.clip(cfg.sigma, cfg.sigma_min, cfg.sigma_max))
        self.variances = np.square(
            np.broadcast_to(self.noise_ramp_scale(), (self.num_nodes, self.nu))
        ).ravel()
        self.path_sigma = np.zeros(n)
        self.path_c = np.zeros(n)
        self.generation = 0
        self.mean = np.zeros(n)
        self._new_cycle = True
        self._normalise_covariance()
        self._clip_spread()

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        self._new_cycle = True
        if (
            self.config.sigma != self._restart_sigma
            or len(self.variances) != len(old_times) * self.nu
        ):
            # a new initial sigma from the GUI, or state that does not belong to the old plan
            self.restart()
            return
        shift = knot_shift_matrix(old_times, new_times)
        for name in ("variances", "path_sigma", "path_c"):
            per_knot = getattr(self, name).reshape(len(old_times), self.nu)
            setattr(self, name, (shift @ per_knot).ravel())
        self._normalise_covariance()
        self._clip_spread()

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        # sizes changed without pre_optimization
        if len(self.variances) != self.num_nodes * self.nu:
            self.restart()
        if self._new_cycle or len(self.mean) != self.num_nodes * self.nu:
            self.mean = nominal_knots.ravel().astype(float)  # warm start from the shifted plan
            self._new_cycle = False
        self._draws = self.rng.standard_normal((self.num_rollouts - 1, len(self.mean)))
        population = self.mean + self.step_size * np.sqrt(self.variances) * self._draws
        return np.concatenate([nominal_knots.reshape(1, -1), population]).reshape(
            self.num_rollouts, self.num_nodes, self.nu
        )

    def samples_replaced(self, rows: np.ndarray, knots: np.ndarray) -> None:
        """Take the candidates at `rows` (a proposal policy's) into the update as injected solutions
        (Hansen 2011, "Injecting external solutions into CMA-ES", arXiv:1110.4181): the draw behind
        each becomes z = (x - m) / (step_size sqrt(C)), its length clipped to c_y = sqrt(n) + 2n /
        (n + 2), so that a far candidate moves the mean, the paths and C no further than a long own
        draw would. Without this the update would credit a candidate's rank to the draw it
        replaced."""
        n = len(self.mean)
        draws = (knots.reshape(len(rows), n) - self.mean) / (
            self.step_size * np.sqrt(self.variances)
        )
        lengths = np.linalg.norm(draws, axis=1, keepdims=True)
        limit = np.sqrt(n) + 2 * n / (n + 2)
        draws *= np.minimum(1.0, limit / np.maximum(lengths, np.finfo(float).tiny))
        self._draws[np.asarray(rows) - 1] = draws

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        n = len(self.mean)
        lam = self.num_rollouts - 1
        p = cmaes_parameters(lam, n)
        population_rewards = rewards[1:]
        # as drawn, before the controller clamped them
        steps = np.sqrt(self.variances) * self._draws
        parents = np.argsort(-population_rewards, kind="stable")[: p.mu]
        weights = np.where(np.isfinite(population_rewards[parents]), p.weights, 0.0)
        if weights.sum() == 0:  # every new sample failed: keep the distribution, keep the plan
            return sampled_knots[0].copy()
        weights /= weights.sum()
        mean_step = weights @ steps[parents]
        self.mean = self.mean + self.step_size * mean_step

        self.generation += 1
        self.path_sigma *= 1 - p.c_sigma
        self.path_sigma += (
            np.sqrt(p.c_sigma * (2 - p.c_sigma) * p.mu_eff) * mean_step / np.sqrt(self.variances)
        )
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
        self._normalise_covariance()
        self._clip_spread()
        if self.config.execute_best:
            return sampled_knots[np.argmax(rewards)].copy()
        return self.mean.reshape(self.num_nodes, self.nu).copy()

    def _normalise_covariance(self) -> None:
        """Move C's overall scale into step_size so that mean(C_ii) = 1 and step_size is the RMS
        std.

        step_size^2 C and the paths in N(0, I) units are unchanged; p_c, in units of step_size, is
        rescaled."""
        scale = float(self.variances.mean())
        self.variances /= scale
        self.path_c /= np.sqrt(scale)
        self.step_size *= np.sqrt(scale)

    def _clip_spread(self) -> None:
        """Keep step_size and every coordinate's std step_size * sqrt(C_ii) within [sigma_min,
        sigma_max]."""
        cfg = self.config
        self.step_size = float(np.clip(self.step_size, cfg.sigma_min, cfg.sigma_max))
        low, high = (cfg.sigma_min / self.step_size) ** 2, (cfg.sigma_max / self.step_size) ** 2
        np.clip(self.variances, low, high, out=self.variances)
