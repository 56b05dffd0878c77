"""Built-in optimizers, registered by name. Each file holds one algorithm and its config."""

from judo.core.registry import register_optimizer
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

register_optimizer("ps", PredictiveSampling, PredictiveSamplingConfig)
register_optimizer("cem", CEM, CEMConfig)
register_optimizer("mppi", MPPI, MPPIConfig)

__all__ = [
    "CEM",
    "CEMConfig",
    "MPPI",
    "MPPIConfig",
    "PredictiveSampling",
    "PredictiveSamplingConfig",
    "register_optimizer",
]
