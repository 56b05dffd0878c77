"""A user's own task and optimizer, referred to by dotted path from judo.toml next to this file."""

from dataclasses import dataclass

import numpy as np

import judo
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.tasks.cartpole import MODEL_PATH


@judo.slider("w_upright", 0.0, 20.0, 0.1)
@dataclass
class BalanceConfig(judo.TaskConfig):
    """Balance-task weights."""

    w_upright: float = 10.0
    """Weight on the pole staying upright."""
    w_control: float = 0.1
    """Weight on small pushes."""


class Balance(judo.Task[BalanceConfig]):
    """Keep the cart-pole's pole upright, starting close to upright."""

    def __init__(self) -> None:
        super().__init__(MODEL_PATH)
        self.reset()

    def reward(self, states, sensors, controls, config, system_metadata=None):
        upright = (1.0 - np.cos(states[..., 1])).sum(-1)
        return -config.w_upright * upright - config.w_control * judo.quadratic_norm(controls).sum(
            -1
        )

    def reset(self) -> None:
        self.data.qpos[:] = [0.0, 0.1 * self.rng.standard_normal()]
        self.data.qvel[:] = 0.0


@dataclass
class CoolingMPPIConfig(MPPIConfig):
    """MPPI whose temperature shrinks by `cooling` after every iteration of a cycle."""

    cooling: float = 0.5
    """Factor applied to the temperature after each iteration (1 = plain MPPI)."""


class CoolingMPPI(MPPI):
    """MPPI with a per-cycle temperature schedule: later iterations trust the best samples more."""

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        self.temperature = self.config.temperature

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        weights = np.exp((rewards - rewards.max()) / self.temperature)
        self.temperature *= self.config.cooling
        return np.tensordot(weights / weights.sum(), sampled_knots, axes=1)
