"""Built-in tasks, registered by name. Each file holds one task and its config; models/ holds the MJCF."""

from judo.core.controller import ControllerConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import register_task, set_config_overrides
from judo.optimizers import CEMConfig, MPPIConfig, PredictiveSamplingConfig
from judo.tasks.cartpole import Cartpole, CartpoleConfig
from judo.tasks.cylinder_push import CylinderPush, CylinderPushConfig

register_task("cartpole", Cartpole, CartpoleConfig)
register_task("cylinder_push", CylinderPush, CylinderPushConfig)

# Per-task defaults that solve each task out of the box (see benchmarks/ and `python -m judo evaluate`).
set_config_overrides("cartpole", ControllerConfig, {"horizon": 1.0, "spline_order": "cubic", "control_freq": 50.0})
set_config_overrides("cartpole", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("cartpole", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("cartpole", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("cartpole", CEMConfig, {"sigma_min": 0.2, "sigma_max": 1.0})

set_config_overrides(
    "cylinder_push", ControllerConfig, {"horizon": 1.0, "spline_order": "linear", "control_freq": 50.0}
)
set_config_overrides("cylinder_push", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("cylinder_push", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("cylinder_push", MPPIConfig, {"sigma": 0.3, "temperature": 0.01})
set_config_overrides("cylinder_push", CEMConfig, {"sigma_min": 0.05, "sigma_max": 0.6})

# --- Classic MPC benchmarks (after MJPC and hydrax) ---------------------------------------------------
from judo.tasks.acrobot import Acrobot, AcrobotConfig  # noqa: E402
from judo.tasks.double_cartpole import DoubleCartpole, DoubleCartpoleConfig  # noqa: E402
from judo.tasks.humanoid_standup import HumanoidStandup, HumanoidStandupConfig  # noqa: E402
from judo.tasks.particle import Particle, ParticleConfig  # noqa: E402
from judo.tasks.pendulum import Pendulum, PendulumConfig  # noqa: E402
from judo.tasks.push_t import PushT, PushTConfig  # noqa: E402
from judo.tasks.walker import Walker, WalkerConfig  # noqa: E402

register_task("pendulum", Pendulum, PendulumConfig)
# An upright pole falls away with a 0.26 s time constant, so open-loop plans longer than ~1 s cannot balance it.
set_config_overrides("pendulum", ControllerConfig, {"horizon": 1.0, "spline_order": "cubic"})
set_config_overrides("pendulum", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("pendulum", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("pendulum", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("pendulum", CEMConfig, {"sigma_min": 0.1, "sigma_max": 0.8, "num_elites": 4})

register_task("particle", Particle, ParticleConfig)
set_config_overrides("particle", ControllerConfig, {"horizon": 1.0, "spline_order": "cubic"})
set_config_overrides("particle", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("particle", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("particle", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
# CEM needs a high noise floor here: its elite mean lags behind when the goal jumps.
set_config_overrides("particle", CEMConfig, {"sigma_min": 0.2, "sigma_max": 0.6, "num_elites": 4})

register_task("acrobot", Acrobot, AcrobotConfig)
# The upright acrobot diverges with a 0.15 s time constant and only the elbow pushes back: 50 Hz replanning
# with two optimizer iterations per cycle holds it up for stretches; none of ps/cem/mppi balances it for good.
set_config_overrides(
    "acrobot", ControllerConfig, {"horizon": 1.0, "spline_order": "cubic", "control_freq": 50.0, "max_opt_iters": 2}
)
set_config_overrides("acrobot", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("acrobot", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("acrobot", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("acrobot", CEMConfig, {"sigma_min": 0.1, "sigma_max": 0.8, "num_elites": 4})

register_task("double_cartpole", DoubleCartpole, DoubleCartpoleConfig)
# Two poles diverge from upright with a 0.14 s time constant: balancing them needs 50 Hz replanning with two
# optimizer iterations per cycle, and a horizon short enough (0.8 s) that open-loop plans stay meaningful.
set_config_overrides(
    "double_cartpole",
    ControllerConfig,
    {"horizon": 0.8, "spline_order": "cubic", "control_freq": 50.0, "max_opt_iters": 2},
)
set_config_overrides("double_cartpole", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("double_cartpole", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("double_cartpole", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("double_cartpole", CEMConfig, {"sigma_min": 0.2, "sigma_max": 0.6, "num_elites": 2})

register_task("push_t", PushT, PushTConfig)
set_config_overrides("push_t", ControllerConfig, {"horizon": 1.0, "spline_order": "linear"})
set_config_overrides("push_t", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("push_t", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("push_t", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("push_t", CEMConfig, {"sigma_min": 0.1, "sigma_max": 0.6, "num_elites": 4})

register_task("walker", Walker, WalkerConfig)
set_config_overrides("walker", ControllerConfig, {"horizon": 0.6, "spline_order": "cubic"})
set_config_overrides("walker", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("walker", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("walker", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("walker", CEMConfig, {"sigma_min": 0.3, "sigma_max": 0.5, "num_elites": 2})

register_task("humanoid_standup", HumanoidStandup, HumanoidStandupConfig)
set_config_overrides("humanoid_standup", ControllerConfig, {"horizon": 0.5, "spline_order": "cubic"})
set_config_overrides("humanoid_standup", OptimizerConfig, {"num_rollouts": 32, "num_nodes": 4})
set_config_overrides("humanoid_standup", PredictiveSamplingConfig, {"sigma": 0.3})
set_config_overrides("humanoid_standup", MPPIConfig, {"sigma": 0.3, "temperature": 0.1})
set_config_overrides("humanoid_standup", CEMConfig, {"sigma_min": 0.3, "sigma_max": 0.5, "num_elites": 2})
# --- end of classic MPC benchmarks ------------------------------------------------------------------------

__all__ = ["Cartpole", "CartpoleConfig", "CylinderPush", "CylinderPushConfig", "register_task"]
