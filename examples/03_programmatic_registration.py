"""03: register your own task and optimizer in Python, set per-task overrides, then start the app.

This is the script form of a config file: everything the file can say, said in Python, followed
by the app's own entry point, so every command-line flag still works:

    python examples/03_programmatic_registration.py                    # GUI at http://localhost:8080
    python examples/03_programmatic_registration.py --headless --duration 5
"""

import sys
from dataclasses import dataclass

import numpy as np

import judo
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.runtime.launch import main
from judo.tasks.cartpole import Cartpole, CartpoleConfig


@dataclass
class SwingHighConfig(CartpoleConfig):
    """Cart-pole weights plus a bonus for a fast tip when the pole is low (to pump energy in)."""

    w_energy: float = 1.0
    """Weight on tip speed while the pole is below horizontal."""


class SwingHigh(Cartpole):
    """The cart-pole swing-up with an energy-pumping bonus on top of the built-in reward."""

    def reward(self, states, sensors, controls, config, system_metadata=None):
        low = np.cos(states[..., 1]) < 0
        pumping = config.w_energy * (low * np.abs(states[..., 3])).sum(-1)
        return super().reward(states, sensors, controls, config, system_metadata) + pumping


@dataclass
class GreedyMPPIConfig(MPPIConfig):
    """MPPI settings plus how far the new nominal leans towards the single best sample."""

    greed: float = 0.5
    """Blend between the MPPI mean (0) and the best sample (1)."""


class GreedyMPPI(MPPI):
    """MPPI blended with predictive sampling: (1 - greed) * weighted mean + greed * best sample."""

    def update_nominal_knots(self, sampled_knots, rewards):
        mean = super().update_nominal_knots(sampled_knots, rewards)
        return (1 - self.config.greed) * mean + self.config.greed * sampled_knots[
            np.argmax(rewards)
        ]


judo.register_task("swing_high", SwingHigh, SwingHighConfig)
judo.register_optimizer("greedy_mppi", GreedyMPPI, GreedyMPPIConfig)
judo.set_config_overrides(
    "swing_high", judo.ControllerConfig, {"horizon": 1.0, "spline_order": "cubic"}
)
judo.set_config_overrides("swing_high", judo.OptimizerConfig, {"num_rollouts": 32})
judo.set_config_overrides("swing_high", GreedyMPPIConfig, {"sigma": 0.3, "greed": 0.3})
judo.set_config_overrides("cylinder_push", GreedyMPPIConfig, {"sigma": 0.3, "temperature": 0.01})

if __name__ == "__main__":
    # Start on our task and optimizer unless the command line names others.
    defaults = (
        [] if "--task" in sys.argv else ["--task", "swing_high", "--optimizer", "greedy_mppi"]
    )
    sys.exit(main(defaults + sys.argv[1:]))
