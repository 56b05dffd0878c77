"""Built-in tasks, registered by name. Each file holds one task and its config; models/ holds the MJCF.

Each task's defaults (the per-task overrides that solve it out of the box, each with a comment on the
sweep that chose it) are data: models/<task>.toml, in the `--config` file format, read by the same loader.
"""

from pathlib import Path

import judo.estimators  # the defaults files name the built-in estimators
import judo.optimizers  # noqa: F401  (the defaults files name the built-in optimizers)
from judo.core.configuration.config_file import load_config
from judo.core.configuration.registry import register_task
from judo.tasks.acrobot import Acrobot, AcrobotConfig
from judo.tasks.car import Car, CarConfig
from judo.tasks.cartpole import Cartpole, CartpoleConfig
from judo.tasks.cartpole_pd import CartpolePD
from judo.tasks.cylinder_push import CylinderPush, CylinderPushConfig
from judo.tasks.double_cartpole import DoubleCartpole, DoubleCartpoleConfig
from judo.tasks.fr3_pick import FR3Pick, FR3PickConfig
from judo.tasks.g1 import G1Stand, G1StandConfig
from judo.tasks.go2 import Go2Stand, Go2StandConfig, Go2Walk, Go2WalkConfig
from judo.tasks.humanoid_standup import HumanoidStandup, HumanoidStandupConfig
from judo.tasks.leap_cube import LeapCube, LeapCubeConfig, LeapCubeDown, LeapCubeDownConfig
from judo.tasks.particle import Particle, ParticleConfig
from judo.tasks.pendulum import Pendulum, PendulumConfig
from judo.tasks.push_t import PushT, PushTConfig
from judo.tasks.quadrotor import Quadrotor, QuadrotorConfig
from judo.tasks.quadruped import Quadruped, QuadrupedConfig
from judo.tasks.quadruped_navigate import QuadrupedNavigate, QuadrupedNavigateConfig
from judo.tasks.quadruped_velocity import QuadrupedVelocity, QuadrupedVelocityConfig
from judo.tasks.walker import Walker, WalkerConfig

DEFAULTS_DIR = Path(__file__).parent / "models"
"""Where each built-in task's defaults file, <task>.toml, lies beside its MJCF."""

BUILTIN_TASKS = {
    "cartpole": (Cartpole, CartpoleConfig),
    # Cart-pole planned through a low-level PD policy: the MPC plans the cart's target (judo.core.rollouts.low_level).
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
    # The same robot tracking a commanded base velocity: the reward `gait-search` teaches the locomotion policy on.
    "quadruped_velocity": (QuadrupedVelocity, QuadrupedVelocityConfig),
    # The same walk to goals, planned in base-velocity commands over the locomotion policy judo taught itself.
    "quadruped_navigate": (QuadrupedNavigate, QuadrupedNavigateConfig),
    # Robot tasks: LEAP hand cube rotation (palm up / palm down) and Franka-style pick-and-place.
    "leap_cube": (LeapCube, LeapCubeConfig),
    "leap_cube_down": (LeapCubeDown, LeapCubeDownConfig),
    "fr3_pick": (FR3Pick, FR3PickConfig),
    # Unitree's G1 humanoid (29 DoF, Unitree's joint PD) standing under random pushes.
    "g1_stand": (G1Stand, G1StandConfig),
    # Unitree Go2 (Menagerie model, Unitree's motor order and PD): stand up from lying and hold under pushes.
    "go2_stand": (Go2Stand, Go2StandConfig),
    # The same Go2 trotting to a velocity command [vx, vy, yaw rate] (--task-config.velocity-command 0.5 0 0).
    "go2_walk": (Go2Walk, Go2WalkConfig),
    # Tasks on their own numpy dynamics (judo.core.rollouts.dynamics), not MuJoCo: a kinematic-bicycle car.
    "car": (Car, CarConfig),
    # A quadrotor rigid body on its four rotor thrusts (numpy equations of motion).
    "quadrotor": (Quadrotor, QuadrotorConfig),
}


def defaults_path(task_name: str) -> Path:
    """The defaults file of the built-in task `task_name` (models/<task>.toml)."""
    return DEFAULTS_DIR / f"{task_name}.toml"


for _name, (_task_cls, _config_cls) in BUILTIN_TASKS.items():
    register_task(_name, _task_cls, _config_cls)
    load_config(defaults_path(_name))


__all__ = [  # every built-in task class and its config
    "Acrobot",
    "AcrobotConfig",
    "Car",
    "CarConfig",
    "Cartpole",
    "CartpoleConfig",
    "CartpolePD",
    "CylinderPush",
    "CylinderPushConfig",
    "DoubleCartpole",
    "DoubleCartpoleConfig",
    "FR3Pick",
    "FR3PickConfig",
    "G1Stand",
    "G1StandConfig",
    "Go2Stand",
    "Go2StandConfig",
    "Go2Walk",
    "Go2WalkConfig",
    "HumanoidStandup",
    "HumanoidStandupConfig",
    "LeapCube",
    "LeapCubeConfig",
    "LeapCubeDown",
    "LeapCubeDownConfig",
    "Particle",
    "ParticleConfig",
    "Pendulum",
    "PendulumConfig",
    "PushT",
    "PushTConfig",
    "Quadrotor",
    "QuadrotorConfig",
    "Quadruped",
    "QuadrupedConfig",
    "QuadrupedNavigate",
    "QuadrupedNavigateConfig",
    "QuadrupedVelocity",
    "QuadrupedVelocityConfig",
    "Walker",
    "WalkerConfig",
    "register_task",
]
