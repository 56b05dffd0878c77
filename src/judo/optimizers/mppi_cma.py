"""MPPI with covariance matrix adaptation: MPPI's weighted mean, and a per-knot covariance learned
from the same weighted samples (the block-diagonal MPPI-CMA of Jordana et al. 2025, with a noise
floor for MPC).

A. Jordana, J. Zhang, J. Amigo, L. Righetti, "An Introduction to Zero-Order Optimization Techniques
for Robotics", arXiv:2506.22087, 2025 (Sec. on MPPI with an adapted covariance, "MPPI-CMA"). The
noise floor and the eigenvalue clamp follow hydrax's MppiCma (V. Kurtz,
github.com/vincekurtz/hydrax).
"""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig, weighted_knots
from judo.optimizers.knot_shift import knot_shift_matrix
from judo.optimizers.mppi import softmax_weights


@slider("sigma", 0.001, 2.0, 0.001)
@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 5.0, 0.001)
@slider("temperature", 0.001, 10.0, 0.001)
@slider("adaptation_rate", 0.0, 1.0, 0.01)
@dataclass
class MPPICMAConfig(OptimizerConfig):
    """MPPI-CMA settings: MPPI's temperature, the initial noise and its bounds, and how fast the
    covariance learns."""

    sigma: float = 0.3
    """Initial noise std of every knot and control, in control units; editing it restarts the
    covariance."""
    sigma_min: float = 0.1
    """Floor on the std along every direction (the covariance's smallest eigenvalue is sigma_min^2),
    so the search never collapses while the MPC problem moves from cycle to cycle."""
    sigma_max: float = 1.0
    """Cap on the std along every direction (the largest eigenvalue is at most sigma_max^2)."""
    temperature: float = 0.1
    """Softmax temperature on rewards, as MPPI's: small follows the best sample, large averages them
    all."""
    adaptation_rate: float = 0.2
    """Weight of this iteration's weighted sample covariance in the new covariance (an exponential
    moving average); 0 keeps the initial covariance (MPPI with a per-knot noise), 1 forgets the old
    one at once."""
    full_covariance: bool = True
    """Learn a full nu x nu covariance per knot (on) or only its diagonal, one std per control
    (off)."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(
            0 < self.sigma_min <= self.sigma_max,
            f"need 0 < sigma_min <= sigma_max, got {self.sigma_min}, {self.sigma_max}",
        )
        require(self.temperature > 0, f"temperature must be positive, got {self.temperature}")
        require_between("adaptation_rate", self.adaptation_rate, 0, 1)


class MPPICMA(Optimizer[MPPICMAConfig]):
    """MPPI whose Gaussian noise has a covariance per knot, adapted from the weighted samples.

    Each iteration samples the nominal (row 0, the plan) and the nominal plus noise eps_ik ~ N(0,
    Sigma_k), one nu x nu covariance Sigma_k per knot k (the block-diagonal variant: knots are
    independent, the controls of one knot are correlated). With w = softmax(rewards / temperature)
    and d_ik = knots_ik - m_k the deviation of sample i from the sampling mean m (the nominal), the
    update is

        m_k <- sum_i w_i knots_ik                                          (MPPI's mean: the new plan)
        S_k = g_k sum_i w_i d_ik d_ik^T                                     (the weighted sample covariance)
        Sigma_k <- clamp((1 - adaptation_rate) Sigma_k + adaptation_rate S_k, sigma_min^2, sigma_max^2)

    where the clamp bounds every eigenvalue (eigh, clip, rebuild) and g_k = 1 here (ER-CMA,
    er_cma.py, inflates it along the horizon). The deviations are of the samples the rollouts
    applied, clamped to the actuator limits and with a proposal policy's candidates in their rows,
    so a saturated control learns a smaller spread there. With full_covariance off, the off-diagonal
    terms are dropped and each control has its own std per knot.

    Between cycles Sigma is re-interpolated to the new knot times (`knot_shift_matrix`: each new
    knot's covariance is a convex combination of old ones, still positive definite), which also
    carries it across a num_nodes edit. Editing `sigma` restarts it at sigma^2 I (times the noise
    ramp squared with use_noise_ramp on; the clamp then applies as to any covariance).

    Attributes:
        covariance: (num_nodes, nu, nu) the sampling covariance of every knot, eigenvalues within
            the bounds.
        root: (num_nodes, nu, nu) a square root R_k of each, R_k R_k^T = Sigma_k, that the noise is
            drawn with.
    """  # noqa: E501

    def __init__(self, config: MPPICMAConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Start again from sigma^2 I at every knot (shaped by the noise ramp)."""
        self._restart_sigma = self.config.sigma
        stds = np.broadcast_to(
            self.config.sigma * self.noise_ramp_scale(), (self.num_nodes, self.nu)
        )
        self._set_covariance(stds[:, :, None] ** 2 * np.eye(self.nu))

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if self.config.sigma != self._restart_sigma or len(self.covariance) != len(old_times):
            # a new initial sigma from the GUI, or a covariance that does not belong to the old plan
            self.restart()
            return
        shift = knot_shift_matrix(old_times, new_times)
        shifted = (shift @ self.covariance.reshape(len(old_times), -1)).reshape(
            len(new_times), self.nu, self.nu
        )
        # a convex combination keeps the eigenvalues within the bounds
        self._set_covariance(shifted, clamp=False)

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        if len(self.covariance) != self.num_nodes:  # sizes changed without pre_optimization
            self.restart()
        self._mean = nominal_knots.copy()
        samples = np.empty((self.num_rollouts, self.num_nodes, self.nu))
        samples[0] = nominal_knots
        draws = self.rng.standard_normal((self.num_nodes, self.num_rollouts - 1, self.nu))
        samples[1:] = np.matmul(draws, self.root.transpose(0, 2, 1)).transpose(1, 0, 2)
        samples[1:] += nominal_knots
        return samples

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        weights = softmax_weights(rewards, self.config.temperature)
        # (num_nodes, num_rollouts, nu)
        deviations = (sampled_knots - self._mean).transpose(1, 0, 2)
        # sum_i w_i d_ik d_ik^T
        weighted = np.matmul(deviations.transpose(0, 2, 1) * weights, deviations)
        weighted *= self.covariance_gain()[:, None, None]
        rate = self.config.adaptation_rate
        self._set_covariance((1 - rate) * self.covariance + rate * weighted)
        return weighted_knots(weights, sampled_knots)

    def covariance_gain(self) -> np.ndarray:
        """(num_nodes,) factor g_k on each knot's weighted sample covariance: ones (ER-CMA inflates
        it)."""
        return np.ones(self.num_nodes)

    def _set_covariance(self, covariance: np.ndarray, clamp: bool = True) -> None:
        """Store (num_nodes, nu, nu) `covariance` with its eigenvalues clamped to [sigma_min^2,
        sigma_max^2] (its diagonal only, with full_covariance off or one control), and the square
        root the noise is drawn with. `clamp=False` is for a covariance already within the bounds:
        its root is its Cholesky factor."""
        cfg = self.config
        low, high = cfg.sigma_min**2, cfg.sigma_max**2
        if not cfg.full_covariance or self.nu == 1:
            variances = np.diagonal(covariance, axis1=1, axis2=2)
            variances = np.clip(variances, low, high) if clamp else variances.copy()
            self.covariance = variances[:, :, None] * np.eye(self.nu)
            self.root = np.sqrt(variances)[:, :, None] * np.eye(self.nu)
        elif not clamp:
            self.covariance = covariance
            self.root = np.linalg.cholesky(covariance)
        else:
            eigenvalues, eigenvectors = np.linalg.eigh(
                0.5 * (covariance + covariance.transpose(0, 2, 1))
            )
            self.root = eigenvectors * np.sqrt(np.clip(eigenvalues, low, high))[:, None, :]
            self.covariance = np.matmul(self.root, self.root.transpose(0, 2, 1))
