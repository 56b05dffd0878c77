"""Predictive sampling (Howell et al. 2022): perturb the nominal, keep the best sample."""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig


@slider("sigma", 0.001, 2.0, 0.001)
@dataclass
class PredictiveSamplingConfig(OptimizerConfig):
    """Predictive sampling settings."""

    sigma: float = 0.05
    """Std of the Gaussian noise added to every knot, in control units."""

    def validate(self) -> None:
        super().validate()
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")


class PredictiveSampling(Optimizer[PredictiveSamplingConfig]):
    """The greedy baseline: the best of the nominal and its perturbations becomes the new
    nominal."""

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        return self.perturb(nominal_knots, self.config.sigma)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        return sampled_knots[np.argmax(rewards)]
