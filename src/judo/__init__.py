"""judo: sampling-based model predictive control on MuJoCo, in plain Python.

import judo
controller = judo.make_controller("cartpole", "mppi")
controller.update_action(state, time)   # state: (nq + nv,)
u = controller.action(time)             # (nu,)

loop = judo.ClosedLoop(controller, judo.MujocoSystem.from_task(controller.task, seed=0))
loop.step()                             # plan when due, serve, step the plant once
"""

from judo.builtin import register_builtins
from judo.core.configuration.config import Config
from judo.core.configuration.config_file import LoadedConfig, load_config
from judo.core.configuration.config_file_text import ConfigFileError
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.fields import np_1d_field, slider
from judo.core.configuration.registry import (
    get_registered_estimators,
    get_registered_optimizers,
    get_registered_tasks,
    make_controller,
    make_estimator,
    register_estimator,
    register_optimizer,
    register_task,
    set_config_overrides,
    set_model_overrides,
)
from judo.core.controller import Controller
from judo.core.errors import (
    ConfigError,
    JudoError,
    ModelLoadError,
    NonFiniteKnotsError,
    NonFiniteRewardError,
    UnknownNameError,
)
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig
from judo.core.lqr import capped_cost_to_go, lqr_cost_to_go
from judo.core.norms import quadratic_norm, smooth_l1_norm, wrap_angle
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.core.policies.onnx_policy import OnnxPolicy
from judo.core.policies.policy_controller import PolicyController, make_policy_controller
from judo.core.policy import Policy, PolicyError
from judo.core.reading import SystemState
from judo.core.rollouts.backend import RandomizedRolloutError
from judo.core.rollouts.dynamics import DynamicsTask
from judo.core.rollouts.low_level import LowLevel
from judo.core.rollouts.randomize import InvalidRandomizedModelError
from judo.core.spline import Spline, SplineBasis
from judo.core.task import Task, TaskConfig
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import PlanRecord, Recorder, StepRecord
from judo.loop.system import DynamicsSystem, MujocoSystem, System
from judo.runtime.app import App
from judo.safety.serve_filter import safety_guard
from judo.version import __version__ as __version__

register_builtins()  # every built-in estimator, optimizer and task, selectable by name

__all__ = [
    "App",
    "ClosedLoop",
    "Config",
    "ConfigError",
    "ConfigFileError",
    "ControlHistory",
    "Controller",
    "ControllerConfig",
    "DynamicsSystem",
    "DynamicsTask",
    "Estimator",
    "EstimatorConfig",
    "InvalidRandomizedModelError",
    "JudoError",
    "LoadedConfig",
    "LowLevel",
    "ModelLoadError",
    "MujocoSystem",
    "NonFiniteKnotsError",
    "NonFiniteRewardError",
    "OnnxPolicy",
    "Optimizer",
    "OptimizerConfig",
    "PlanRecord",
    "Policy",
    "PolicyController",
    "PolicyError",
    "RandomizedRolloutError",
    "Recorder",
    "Spline",
    "SplineBasis",
    "StepRecord",
    "System",
    "SystemState",
    "Task",
    "TaskConfig",
    "UnknownNameError",
    "capped_cost_to_go",
    "get_registered_estimators",
    "get_registered_optimizers",
    "get_registered_tasks",
    "load_config",
    "lqr_cost_to_go",
    "make_controller",
    "make_estimator",
    "make_policy_controller",
    "np_1d_field",
    "quadratic_norm",
    "register_estimator",
    "register_optimizer",
    "register_task",
    "safety_guard",
    "set_config_overrides",
    "set_model_overrides",
    "slider",
    "smooth_l1_norm",
    "wrap_angle",
]
