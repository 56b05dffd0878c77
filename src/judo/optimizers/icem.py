"""Improved cross-entropy method, iCEM (Pinneri et al. 2020): colored noise and elites kept across iterations.

C. Pinneri, S. Sawant, S. Blaes, J. Achterhold, J. Stueckler, M. Rolinek, G. Martius, "Sample-efficient
Cross-Entropy Method for Real-time Planning", CoRL 2020, arXiv:2008.06389.
"""

from dataclasses import dataclass

import numpy as np

from judo.core.config import require
from judo.core.fields import slider
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.knot_shift import shift_knots


@slider("elite_keep_fraction", 0.0, 1.0, 0.05)
@slider("beta", 0.0, 4.0, 0.1)
@dataclass
class ICEMConfig(CEMConfig):
    """iCEM settings: CEM's (sigma_min, sigma_max, num_elites) plus the noise color and the elite memory."""

    elite_keep_fraction: float = 0.3
    """Fraction of num_elites carried into the next iteration's samples (shifted in time between cycles)."""
    beta: float = 2.0
    """Noise color: power spectrum ~ 1/f^beta along the knots; 0 is white, 2 is Brownian-like, larger is smoother."""

    def validate(self) -> None:
        super().validate()
        require(
            0.0 <= self.elite_keep_fraction <= 1.0,
            f"elite_keep_fraction must be between 0 and 1, got {self.elite_keep_fraction}",
        )
        require(self.beta >= 0, f"beta must be at least 0, got {self.beta}")


class ICEM(CEM):
    """CEM with iCEM's sampling: colored noise, and the best elites of each iteration sampled again.

    Each iteration's samples are [nominal, kept elites, nominal + sigma * colored noise]; the new
    nominal and std are the elites' mean and std as in CEM (clipped to [sigma_min, sigma_max]). The
    noise along the knot axis has power spectrum ~ 1/f^beta, so beta > 0 favours smooth, low-frequency
    changes of the plan over jittery ones. After each update the best round(elite_keep_fraction *
    num_elites) samples are kept; at the start of a cycle they, and sigma, are shifted to the new knot
    times by linear interpolation (which also carries them across a num_nodes edit), and a num_rollouts
    edit only changes how many fresh samples are drawn.

    Unlike the paper: the population size is fixed (judo's batch is num_rollouts every iteration, so
    there is no population decay), there is no momentum on the mean and std, the executed plan is the
    elite mean (judo's nominal is both the plan and the next centre) rather than the best sample, and
    sigma carries over between cycles as in judo's CEM instead of restarting at its initial value.
    Shifted elites are interpolated linearly even under a cubic plan spline, so they are close to,
    not exactly, their own continuation.

    Attributes:
        sigma: (num_nodes, nu) current sampling std.
        kept_elites: (num_kept, num_nodes, nu) elites carried into the next iteration.
    """

    config: ICEMConfig

    def __init__(self, config: ICEMConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Widest sigma (sigma_max) and no kept elites."""
        self.sigma = np.full((self.num_nodes, self.nu), self.config.sigma_max)
        self.kept_elites = np.zeros((0, self.num_nodes, self.nu))

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if len(self.sigma) != len(old_times):  # state that does not belong to the old plan
            self.restart()
            return
        self.sigma = shift_knots(self.sigma, old_times, new_times)
        self.kept_elites = shift_knots(self.kept_elites, old_times, new_times)

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        if len(self.sigma) != self.num_nodes:  # sizes changed without pre_optimization
            self.restart()
        kept = self.kept_elites[: self.num_rollouts - 1]
        num_fresh = self.num_rollouts - 1 - len(kept)
        noise = colored_noise(self.rng, self.config.beta, (num_fresh, self.nu, self.num_nodes)).transpose(0, 2, 1)
        fresh = nominal_knots + noise * (self.sigma * self.noise_ramp_scale())
        return np.concatenate([nominal_knots[None], kept, fresh])

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        nominal = super().update_nominal_knots(sampled_knots, rewards)
        num_kept = min(round(self.config.elite_keep_fraction * self.config.num_elites), self.num_rollouts - 1)
        best = np.argsort(-rewards, kind="stable")[:num_kept]
        self.kept_elites = sampled_knots[best[np.isfinite(rewards[best])]].copy()
        return nominal


def colored_noise(rng: np.random.Generator, beta: float, shape: tuple[int, ...]) -> np.ndarray:
    """Gaussian noise of `shape` (..., n), unit variance per entry, stationary along the last axis with
    power spectrum proportional to 1/f^beta (the zero frequency gets the lowest one's power, 1/n).

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
