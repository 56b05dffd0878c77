"""judo's built-in estimators, optimizers and tasks by name, and `register_builtins`, which
registers them all (and the config files' [safety.TASK] section, whose class lives in judo.safety).

`import judo` calls `register_builtins()`, so every name below is selectable
(`make_controller("cartpole", "mppi")`, `--estimator ekf`) as soon as any part of judo is imported.
Each task's defaults (the per-task overrides that solve it out of the box, each with a comment on
the sweep that chose it) are data: tasks/models/<task>.toml, in the `--config` file format, loaded
by the same loader right after the task is registered.
"""

from pathlib import Path

from judo.core.configuration.config_file import load_config, register_task_section
from judo.core.configuration.registry import register_estimator, register_optimizer, register_task
from judo.estimators.ekf import EKFConfig, ExtendedKalmanFilter
from judo.estimators.legged import LeggedConfig, LeggedEstimator
from judo.estimators.state import StateEstimator, StateEstimatorConfig
from judo.estimators.ukf import UKFConfig, UnscentedKalmanFilter
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
from judo.safety.limits import SECTION_CONFIG, check_section
from judo.tasks.acrobot import Acrobot, AcrobotConfig
from judo.tasks.car import Car, CarConfig
from judo.tasks.cartpole import Cartpole, CartpoleConfig
from judo.tasks.cartpole_pd import CartpolePD
from judo.tasks.cylinder_push import CylinderPush, CylinderPushConfig
from judo.tasks.double_cartpole import DoubleCartpole, DoubleCartpoleConfig
from judo.tasks.fr3_pick import FR3Pick, FR3PickConfig
from judo.tasks.humanoid_standup import HumanoidStandup, HumanoidStandupConfig
from judo.tasks.leap_cube import LeapCube, LeapCubeConfig, LeapCubeDown, LeapCubeDownConfig
from judo.tasks.particle import Particle, ParticleConfig
from judo.tasks.pendulum import Pendulum, PendulumConfig
from judo.tasks.push_t import PushT, PushTConfig
from judo.tasks.quadrotor import Quadrotor, QuadrotorConfig
from judo.tasks.quadruped import Quadruped, QuadrupedConfig
from judo.tasks.quadruped_navigate import QuadrupedNavigate, QuadrupedNavigateConfig
from judo.tasks.quadruped_velocity import QuadrupedVelocity, QuadrupedVelocityConfig
from judo.tasks.unitree.g1 import G1Stand, G1StandConfig
from judo.tasks.unitree.go2 import Go2Stand, Go2StandConfig, Go2Walk, Go2WalkConfig
from judo.tasks.walker import Walker, WalkerConfig

BUILTIN_ESTIMATORS = {
    "state": (StateEstimator, StateEstimatorConfig),
    "ekf": (ExtendedKalmanFilter, EKFConfig),
    "ukf": (UnscentedKalmanFilter, UKFConfig),
    "legged": (LeggedEstimator, LeggedConfig),
}
"""Each built-in estimator's name -> (estimator class, config class); each lives in
judo/estimators/."""

BUILTIN_OPTIMIZERS = {
    "ps": (PredictiveSampling, PredictiveSamplingConfig),
    "cem": (CEM, CEMConfig),
    "mppi": (MPPI, MPPIConfig),
    "dial": (Dial, DialConfig),
    "cmaes": (CMAES, CMAESConfig),
    "icem": (ICEM, ICEMConfig),
    "ilqr": (ILQR, ILQRConfig),
    "mppi_cma": (MPPICMA, MPPICMAConfig),
    "er_cma": (ERCMA, ERCMAConfig),
    "mtp": (MTP, MTPConfig),
    "cbo": (CBO, CBOConfig),
}
"""Each built-in optimizer's name -> (optimizer class, config class); each lives in
judo/optimizers/."""

DEFAULTS_DIR = Path(__file__).parent / "tasks" / "models"
"""Where each built-in task's defaults file, <task>.toml, lies beside its MJCF."""

BUILTIN_TASKS = {
    "cartpole": (Cartpole, CartpoleConfig),
    # Cart-pole planned through a low-level PD policy: the MPC plans the cart's
    # target (judo.core.rollouts.low_level).
    "cartpole_pd": (CartpolePD, CartpoleConfig),
    "cylinder_push": (CylinderPush, CylinderPushConfig),
    # Classic MPC benchmarks (after MJPC and hydrax).
    "pendulum": (Pendulum, PendulumConfig),
    "particle": (Particle, ParticleConfig),
    "acrobot": (Acrobot, AcrobotConfig),
    "double_cartpole": (DoubleCartpole, DoubleCartpoleConfig),
    "push_t": (PushT, PushTConfig),
    "walker": (Walker, WalkerConfig),
    "humanoid_standup": (HumanoidStandup, HumanoidStandupConfig),
    # A Go1-class quadruped planned directly in its 12 joint targets: walk to goals.
    "quadruped": (Quadruped, QuadrupedConfig),
    # The same robot tracking a commanded base velocity: the reward `gait-search` teaches the
    # locomotion policy on.
    "quadruped_velocity": (QuadrupedVelocity, QuadrupedVelocityConfig),
    # The same walk to goals, planned in base-velocity commands over the locomotion policy judo
    # taught itself.
    "quadruped_navigate": (QuadrupedNavigate, QuadrupedNavigateConfig),
    # Robot tasks: LEAP hand cube rotation (palm up / palm down) and Franka-style pick-and-place.
    "leap_cube": (LeapCube, LeapCubeConfig),
    "leap_cube_down": (LeapCubeDown, LeapCubeDownConfig),
    "fr3_pick": (FR3Pick, FR3PickConfig),
    # Unitree's G1 humanoid (29 DoF, Unitree's joint PD) standing under random pushes.
    "g1_stand": (G1Stand, G1StandConfig),
    # Unitree Go2 (Menagerie model, Unitree's motor order and PD): stand up from lying and hold
    # under pushes.
    "go2_stand": (Go2Stand, Go2StandConfig),
    # The same Go2 trotting to a velocity command [vx, vy, yaw
    # rate] (--task-config.velocity-command 0.5 0 0).
    "go2_walk": (Go2Walk, Go2WalkConfig),
    # Tasks on their own numpy dynamics (judo.core.rollouts.dynamics), not MuJoCo: a
    # kinematic-bicycle car.
    "car": (Car, CarConfig),
    # A quadrotor rigid body on its four rotor thrusts (numpy equations of motion).
    "quadrotor": (Quadrotor, QuadrotorConfig),
}
"""Each built-in task's name -> (task class, config class); each lives in judo/tasks/."""

_registered = False


def defaults_path(task_name: str) -> Path:
    """The defaults file of the built-in task `task_name` (tasks/models/<task>.toml)."""
    return DEFAULTS_DIR / f"{task_name}.toml"


def register_builtins() -> None:
    """Register the config files' [safety.TASK] section (judo.safety.limits), the built-in
    estimators, then the optimizers, then each task followed by its defaults file (which names the
    built-in estimators and optimizers). Only the first call registers: a later one leaves the
    registries, and whatever a user registered over a built-in name, as they are."""
    global _registered
    if _registered:
        return
    _registered = True
    register_task_section("safety", SECTION_CONFIG, check_section)
    for name, (estimator_cls, estimator_config_cls) in BUILTIN_ESTIMATORS.items():
        register_estimator(name, estimator_cls, estimator_config_cls)
    for name, (optimizer_cls, optimizer_config_cls) in BUILTIN_OPTIMIZERS.items():
        register_optimizer(name, optimizer_cls, optimizer_config_cls)
    for name, (task_cls, task_config_cls) in BUILTIN_TASKS.items():
        register_task(name, task_cls, task_config_cls)
        load_config(defaults_path(name))
