"""Improved cross-entropy method, iCEM (Pinneri et al. 2020): colored noise and elites kept across
iterations.

C. Pinneri, S. Sawant, S. Blaes, J. Achterhold, J. Stueckler, M. Rolinek, G. Martius,
"Sample-efficient Cross-Entropy Method for Real-time Planning", CoRL 2020, arXiv:2008.06389.
"""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.optimizers.cem import check_elite_settings
from judo.optimizers.knot_shift import shift_knots


@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 2.0, 0.001)
@slider("num_elites", 1, 128, 1)
@slider("elite_keep_fraction", 0.0, 1.0, 0.05)
@slider("beta", 0.0, 4.0, 0.1)
@dataclass
class ICEMConfig(OptimizerConfig):
    """iCEM settings: CEM's std bounds and elite count, the noise color, and the elite memory."""

    sigma_min: float = 0.15
    """Lower bound on the per-knot noise std, so the search never collapses."""
    sigma_max: float = 0.5
    """Upper bound on the per-knot noise std, and its initial value."""
    num_elites: int = 4
    """Best samples the Gaussian is fitted to (at most num_rollouts)."""
    elite_keep_fraction: float = 0.3
    """Fraction of num_elites carried into the next iteration's samples (shifted in time between
    cycles)."""
    beta: float = 1.0
    """Noise color: power spectrum ~ 1/f^beta along the knots; 0 is white, 2 is Brownian-like,
    larger is smoother."""

    def validate(self) -> None:
        super().validate()
        check_elite_settings(self)
        require(
            0.0 <= self.elite_keep_fraction <= 1.0,
            f"elite_keep_fraction must be between 0 and 1, got {self.elite_keep_fraction}",
        )
        require_between("beta", self.beta, 0, 10)


class ICEM(Optimizer[ICEMConfig]):
    """iCEM: a CEM distribution sampled with colored noise, elites remembered, and the best sample
    executed.

    The optimizer keeps a Gaussian (mean, per-knot std sigma) like CEM. Each iteration samples

        [nominal, mean, kept elites, mean + sigma * colored noise],

    where the nominal is the plan (the best sample so far; at the start of a cycle, the previous
    plan shifted by the controller). The noise along the knot axis has power spectrum ~ 1/f^beta, so
    beta > 0 favours smooth, low-frequency changes of the plan over jittery ones. The update refits
    mean and sigma to the num_elites best samples (sigma clipped to [sigma_min, sigma_max]), keeps
    the best round(elite_keep_fraction * num_elites) of them for the next iteration, and returns the
    best sample as the new plan, as the paper executes the best sequence rather than the mean. At
    the start of a cycle the mean, sigma and kept elites are shifted to the new knot times by linear
    interpolation, which also carries them across a num_nodes edit; a num_rollouts edit only changes
    how many fresh samples are drawn.

    Unlike the paper: the population size is fixed (judo's batch is num_rollouts every iteration, so
    there is no population decay); there is no momentum on mean and std; the mean is evaluated every
    iteration, not only the last (the optimizer does not know which is last); and sigma carries over
    between cycles, shifted, instead of restarting at its initial value, because judo often runs a
    single iteration per cycle. Shifted elites are interpolated linearly even under a cubic plan
    spline, so they are close to, not exactly, their own continuation.

    Attributes:
        mean: (num_nodes, nu) centre of the sampling distribution, or None until the first sample.
        sigma: (num_nodes, nu) current sampling std, before the noise ramp (see CEM).
        kept_elites: (num_kept, num_nodes, nu) elites carried into the next iteration, the plan
            excluded.
    """

    def __init__(self, config: ICEMConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Forget the distribution: mean from the next nominal, widest sigma (sigma_max), no kept
        elites."""
        self.mean: np.ndarray | None = None
        self.sigma = np.full((self.num_nodes, self.nu), self.config.sigma_max)
        self.kept_elites = np.zeros((0, self.num_nodes, self.nu))

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if len(self.sigma) != len(old_times):  # state that does not belong to the old plan
            self.restart()
            return
        self.sigma = shift_knots(self.sigma, old_times, new_times)
        self.kept_elites = shift_knots(self.kept_elites, old_times, new_times)
        if self.mean is not None:
            self.mean = shift_knots(self.mean, old_times, new_times)

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        if len(self.sigma) != self.num_nodes:  # sizes changed without pre_optimization
            self.restart()
        mean = self.mean = nominal_knots.copy() if self.mean is None else self.mean
        fixed = np.concatenate([nominal_knots[None], mean[None], self.kept_elites])[
            : self.num_rollouts
        ]
        num_fresh = self.num_rollouts - len(fixed)
        noise = colored_noise(
            self.rng, self.config.beta, (num_fresh, self.nu, self.num_nodes)
        ).transpose(0, 2, 1)
        fresh = mean + noise * (self.sigma * self.noise_ramp_scale())
        return np.concatenate([fixed, fresh])

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        cfg = self.config
        ranked = np.argsort(-rewards, kind="stable")
        ranked = ranked[np.isfinite(rewards[ranked])]
        elites = sampled_knots[ranked[: cfg.num_elites]]
        self.mean = elites.mean(axis=0)
        self.sigma = np.clip(
            elites.std(axis=0) / self.noise_ramp_scale(), cfg.sigma_min, cfg.sigma_max
        )
        num_kept = round(cfg.elite_keep_fraction * cfg.num_elites)
        self.kept_elites = elites[1:num_kept].copy()
        return elites[0].copy()


def colored_noise(rng: np.random.Generator, beta: float, shape: tuple[int, ...]) -> np.ndarray:
    """Gaussian noise of `shape` (..., n), unit variance per entry, stationary along the last axis
    with power spectrum proportional to 1/f^beta (the zero frequency gets the lowest one's power,
    1/n).

    Made in the frequency domain: every rfft bin k gets a complex Gaussian of expected power
    2 f_k^-beta (a real Gaussian for the bins whose DFT value is real), then `irfft` and a division
    by the exact std the construction gives. beta = 0 is white noise. Like any FFT construction the
    sequence is periodic, so the ends are correlated with each other.
    """
    n = shape[-1]
    freqs = np.fft.rfftfreq(n)
    freqs[0] = freqs[1] if n > 1 else 1.0
    amplitude = freqs ** (-beta / 2)
    bins = (*shape[:-1], len(freqs))
    real = rng.standard_normal(bins)
    imag = rng.standard_normal(bins)
    real_valued = [0, n // 2] if n % 2 == 0 else [0]
    real[..., real_valued] *= np.sqrt(2.0)
    imag[..., real_valued] = 0.0
    noise = np.fft.irfft((real + 1j * imag) * amplitude, n=n, axis=-1)
    multiplicity = np.full(len(freqs), 2.0)
    multiplicity[real_valued] = 1.0
    variance = 2.0 * (multiplicity * amplitude**2).sum() / n**2
    return noise / np.sqrt(variance)
