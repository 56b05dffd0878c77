"""Built-in optimizers, registered by name. Each file holds one algorithm and its config."""

from judo.core.configuration.registry import register_optimizer
from judo.optimizers.cbo import CBO, CBOConfig
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.cmaes import CMAES, CMAESConfig
from judo.optimizers.dial import Dial, DialConfig
from judo.optimizers.er_cma import ERCMA, ERCMAConfig
from judo.optimizers.icem import ICEM, ICEMConfig
from judo.optimizers.ilqr import ILQR, ILQRConfig
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.mppi_cma import MPPICMA, MPPICMAConfig
from judo.optimizers.mtp import MTP, MTPConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

register_optimizer("ps", PredictiveSampling, PredictiveSamplingConfig)
register_optimizer("cem", CEM, CEMConfig)
register_optimizer("mppi", MPPI, MPPIConfig)
register_optimizer("dial", Dial, DialConfig)
register_optimizer("cmaes", CMAES, CMAESConfig)
register_optimizer("icem", ICEM, ICEMConfig)
register_optimizer("ilqr", ILQR, ILQRConfig)
register_optimizer("mppi_cma", MPPICMA, MPPICMAConfig)
register_optimizer("er_cma", ERCMA, ERCMAConfig)
register_optimizer("mtp", MTP, MTPConfig)
register_optimizer("cbo", CBO, CBOConfig)

__all__ = [
    "CBO",
    "CBOConfig",
    "CEM",
    "CEMConfig",
    "CMAES",
    "CMAESConfig",
    "Dial",
    "DialConfig",
    "ERCMA",
    "ERCMAConfig",
    "ICEM",
    "ICEMConfig",
    "ILQR",
    "ILQRConfig",
    "MPPI",
    "MPPICMA",
    "MPPICMAConfig",
    "MPPIConfig",
    "MTP",
    "MTPConfig",
    "PredictiveSampling",
    "PredictiveSamplingConfig",
    "register_optimizer",
]
