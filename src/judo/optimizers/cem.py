"""Cross-entropy method (Rubinstein 1999): fit a Gaussian to the elite samples."""

from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig


@slider("sigma_min", 0.001, 2.0, 0.001)
@slider("sigma_max", 0.001, 2.0, 0.001)
@slider("num_elites", 1, 128, 1)
@dataclass
class CEMConfig(OptimizerConfig):
    """CEM settings."""

    sigma_min: float = 0.05
    """Lower bound on the per-knot noise std, so the search never collapses."""
    sigma_max: float = 0.5
    """Upper bound on the per-knot noise std, and its initial value."""
    num_elites: int = 4
    """Best samples the Gaussian is fitted to (at most num_rollouts)."""

    def validate(self) -> None:
        super().validate()
        check_elite_settings(self)


class CEM(Optimizer[CEMConfig]):
    """Samples around the nominal with a per-knot std; the new nominal and std are the elites' mean
    and std (clipped to [sigma_min, sigma_max]). The std carries over between cycles.

    Attributes:
        sigma: (num_nodes, nu) current sampling std, before the noise ramp (with use_noise_ramp on,
            the samples' std is sigma times `noise_ramp_scale()`, and the elites' std is divided by
            it again).
    """

    def __init__(self, config: CEMConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Start wide again: sigma_max on every knot."""
        self.sigma = np.full((self.num_nodes, self.nu), self.config.sigma_max)

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if self.sigma.shape != (self.num_nodes, self.nu):  # num_nodes changed
            self.restart()

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        return self.perturb(nominal_knots, self.sigma)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        num_elites = min(self.config.num_elites, self.num_rollouts)
        elites = sampled_knots[np.argsort(-rewards, kind="stable")[:num_elites]]
        spread = elites.std(axis=0) / self.noise_ramp_scale()
        self.sigma = np.clip(spread, self.config.sigma_min, self.config.sigma_max)
        return elites.mean(axis=0)


def check_elite_settings(config: Any) -> None:
    """Raise ConfigError unless 0 < sigma_min <= sigma_max and 1 <= num_elites <= num_rollouts.

    Shared by CEMConfig and ICEMConfig, which have these fields but no common base beyond
    OptimizerConfig.
    """
    require(
        0 < config.sigma_min <= config.sigma_max,
        f"need 0 < sigma_min <= sigma_max, got {config.sigma_min}, {config.sigma_max}",
    )
    require(
        1 <= config.num_elites <= config.num_rollouts,
        f"num_elites must be between 1 and num_rollouts ({config.num_rollouts}), got "
        f"{config.num_elites}",
    )
