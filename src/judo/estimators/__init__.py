"""Built-in estimators, registered by name. Each file holds one estimator and its config."""

from judo.core.configuration.registry import register_estimator
from judo.estimators.ekf import EKFConfig, ExtendedKalmanFilter
from judo.estimators.legged import LeggedConfig, LeggedEstimator
from judo.estimators.state import StateEstimator, StateEstimatorConfig
from judo.estimators.ukf import UKFConfig, UnscentedKalmanFilter

register_estimator("state", StateEstimator, StateEstimatorConfig)
register_estimator("ekf", ExtendedKalmanFilter, EKFConfig)
register_estimator("ukf", UnscentedKalmanFilter, UKFConfig)
register_estimator("legged", LeggedEstimator, LeggedConfig)

__all__ = [
    "EKFConfig",
    "ExtendedKalmanFilter",
    "LeggedConfig",
    "LeggedEstimator",
    "StateEstimator",
    "StateEstimatorConfig",
    "UKFConfig",
    "UnscentedKalmanFilter",
    "register_estimator",
]
