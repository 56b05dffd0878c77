"""Built-in optimizers, registered by name. Each file holds one algorithm and its config."""

from judo.core.registry import register_optimizer
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.cmaes import CMAES, CMAESConfig
from judo.optimizers.dial import Dial, DialConfig
from judo.optimizers.icem import ICEM, ICEMConfig
from judo.optimizers.ilqr import ILQR, ILQRConfig
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

register_optimizer("ps", PredictiveSampling, PredictiveSamplingConfig)
register_optimizer("cem", CEM, CEMConfig)
register_optimizer("mppi", MPPI, MPPIConfig)
register_optimizer("dial", Dial, DialConfig)
register_optimizer("cmaes", CMAES, CMAESConfig)
register_optimizer("icem", ICEM, ICEMConfig)
register_optimizer("ilqr", ILQR, ILQRConfig)

__all__ = [
    "CEM",
    "CEMConfig",
    "CMAES",
    "CMAESConfig",
    "Dial",
    "DialConfig",
    "ICEM",
    "ICEMConfig",
    "ILQR",
    "ILQRConfig",
    "MPPI",
    "MPPIConfig",
    "PredictiveSampling",
    "PredictiveSamplingConfig",
    "register_optimizer",
]
