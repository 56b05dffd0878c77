"""What the tests of mppi_cma, er_cma, mtp and cbo share: a closed-loop swing-up with the task's
defaults, and one update through robust planning, proposals and a low-level policy (not a test
module: no tests are collected here)."""

import numpy as np

import judo
from judo.core.configuration.config import with_updates
from judo.core.configuration.registry import make_config
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.cartpole_pd import CartpolePD

SWING_UP = {
    "pendulum": ("upright_fraction", 7.0, None),
    "cartpole": ("balanced_fraction", 6.0, 20.0),
}
"""Task -> (metric, episode seconds, replanning rate or None for the task's own): the pendulum's
upright share of the last 3 s, the cart-pole's balanced share of the last 3 s (at 20 Hz, a rate its
defaults are checked at)."""


def swing_up_metric(task_name: str, optimizer: str, seed: int = 0) -> float:
    """The swing-up metric of one seeded closed-loop episode of `task_name` under `optimizer`'s
    defaults there."""
    metric, duration, rate = SWING_UP[task_name]
    controller = judo.make_controller(task_name, optimizer, seed=seed)
    if rate is not None:
        controller.config = with_updates(controller.config, {"control_freq": rate})
    plant = MujocoSystem.from_task(controller.task, seed=seed)
    log = run_episode(controller, plant, duration=duration).log
    controller.close()
    return plant.task.metrics(log)[metric]


class TargetChunks(judo.Policy):
    """A chunk policy proposing the same cart target everywhere, for cartpole_pd's commands."""

    def __init__(self, observation_size: int, value: float, horizon: int = 4) -> None:
        self.observation_size, self.action_size, self.horizon = observation_size, 1, horizon
        self.metadata = {"name": "target_chunks"}
        self.value = value

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), self.horizon, 1), self.value)


def plan_with_everything(optimizer: str, cycles: int = 3) -> judo.Controller:
    """`cycles` updates of cartpole_pd (a low-level PD policy runs the commands) under `optimizer`,
    with three randomized models scored by CVaR and 4 of the 16 candidates proposed by a policy;
    returns the closed controller."""
    config = with_updates(
        make_config(judo.ControllerConfig, "cartpole_pd"),
        {"num_randomizations": 3, "risk": "cvar", "policy_samples": 4, "horizon": 0.5},
    )
    optimizer_config = with_updates(
        make_config(judo.get_registered_optimizers()[optimizer][1], "cartpole_pd"),
        {"num_rollouts": 16},
    )
    policy = TargetChunks(CartpolePD().policy_observation_size(), 0.2)
    controller = judo.make_controller(
        "cartpole_pd",
        optimizer,
        seed=0,
        num_workers=1,
        controller_config=config,
        optimizer_config=optimizer_config,
        proposal_policy=policy,
    )
    with controller:
        for step in range(cycles):
            controller.update_action(np.array([0.0, np.pi, 0.0, 0.0]), 0.05 * step)
    return controller
