"""Model predictive path integral control (Williams et al. 2017): a softmax-weighted mean of
samples."""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig, weighted_knots


@slider("sigma", 0.001, 2.0, 0.001)
@slider("temperature", 0.001, 10.0, 0.001)
@dataclass
class MPPIConfig(OptimizerConfig):
    """MPPI settings."""

    sigma: float = 0.05
    """Std of the Gaussian noise added to every knot, in control units."""
    temperature: float = 0.1
    """Softmax temperature on rewards: small follows the best sample, large averages them all. It is
    in the task's reward units, so size it to how much the rewards of a cycle's samples differ
    (leap_cube: 0.001)."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(self.temperature > 0, f"temperature must be positive, got {self.temperature}")


class MPPI(Optimizer[MPPIConfig]):
    """Samples like predictive sampling; the new nominal is sum_i w_i knots_i, w = softmax(rewards /
    temperature)."""

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        return self.perturb(nominal_knots, self.config.sigma)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        weights = softmax_weights(rewards, self.config.temperature)
        return weighted_knots(weights, sampled_knots)


def softmax_weights(rewards: np.ndarray, temperature: float) -> np.ndarray:
    """(num_rollouts,) weights summing to 1, exp((r - max r) / temperature); -inf rewards get 0."""
    weights = np.exp((rewards - rewards.max()) / temperature)
    return weights / weights.sum()
