"""Entropy-regularized covariance matrix adaptation (ER-CMA): MPPI-CMA whose learned covariance is
inflated by an entropy bonus that grows along the horizon, smoothed by a moving average, its
eigenvalues clamped.

A. Jordana, J. Zhang, J. Amigo, L. Righetti, "An Introduction to Zero-Order Optimization Techniques
for Robotics", arXiv:2506.22087, 2025 (the MPPI-CMA update this builds on, with its
entropy-regularized view of the sampling distribution). The per-knot entropy bonus, its linear
growth along the horizon and the two-sided eigenvalue clamp are those of hydrax's ErCma (V. Kurtz,
github.com/vincekurtz/hydrax, hydrax/algs/er_cma.py).
"""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.optimizers.mppi_cma import MPPICMA, MPPICMAConfig

MAX_ENTROPY_BONUS = 0.95
"""Largest entropy bonus: the covariance gain 1 / (1 - bonus) is then 20."""


@slider("entropy_bonus_start", 0.0, MAX_ENTROPY_BONUS, 0.01)
@slider("entropy_bonus_end", 0.0, MAX_ENTROPY_BONUS, 0.01)
@dataclass
class ERCMAConfig(MPPICMAConfig):
    """ER-CMA settings: MPPI-CMA's, and the entropy bonus at the first and the last knot."""

    entropy_bonus_start: float = 0.0
    """Entropy bonus beta at the first knot, in [0, 0.95]: its learned covariance is divided by 1 -
    beta."""
    entropy_bonus_end: float = 0.5
    """Entropy bonus at the last knot; the bonus grows linearly from entropy_bonus_start to it, so
    the far knots, whose effect the next cycles can still correct, keep exploring more than the near
    ones."""

    def validate(self) -> None:
        super().validate()
        for name in ("entropy_bonus_start", "entropy_bonus_end"):
            value = getattr(self, name)
            require(
                0 <= value <= MAX_ENTROPY_BONUS,
                f"{name} must be between 0 and {MAX_ENTROPY_BONUS}, got {value}",
            )


class ERCMA(MPPICMA):
    """MPPI-CMA with an entropy bonus on the covariance that grows along the horizon.

    The update is MPPICMA's (see there) with the gain g_k = 1 / (1 - beta_k) on knot k's weighted
    sample covariance, beta_k growing linearly from entropy_bonus_start at the first knot to
    entropy_bonus_end at the last. Maximising the weighted log-likelihood plus beta times the
    Gaussian's entropy has this inflated covariance as its solution: the weighted samples alone
    shrink the covariance towards the best ones, and the bonus keeps a share of the spread (more of
    it where the plan is least certain). The inflated estimate is then smoothed with the old
    covariance (adaptation_rate) and its eigenvalues clamped to [sigma_min^2, sigma_max^2], as in
    MPPI-CMA.
    """

    config: ERCMAConfig

    def covariance_gain(self) -> np.ndarray:
        """(num_nodes,) 1 / (1 - beta_k), with beta_k linear from entropy_bonus_start to
        entropy_bonus_end."""
        bonus = np.linspace(
            self.config.entropy_bonus_start, self.config.entropy_bonus_end, self.num_nodes
        )
        return 1.0 / (1.0 - bonus)
