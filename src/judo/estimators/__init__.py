"""Built-in estimators, registered by name. Each file holds one estimator and its config."""

from judo.core.registry import register_estimator
from judo.estimators.ekf import EKFConfig, ExtendedKalmanFilter
from judo.estimators.state import StateEstimator, StateEstimatorConfig
from judo.estimators.ukf import UKFConfig, UnscentedKalmanFilter

register_estimator("state", StateEstimator, StateEstimatorConfig)
register_estimator("ekf", ExtendedKalmanFilter, EKFConfig)
register_estimator("ukf", UnscentedKalmanFilter, UKFConfig)

__all__ = [
    "EKFConfig",
    "ExtendedKalmanFilter",
    "StateEstimator",
    "StateEstimatorConfig",
    "UKFConfig",
    "UnscentedKalmanFilter",
    "register_estimator",
]
