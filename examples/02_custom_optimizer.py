"""02: write an optimizer, register it, and compare it with MPPI on cartpole.

An optimizer is two methods: sample knots around the nominal, and make a new nominal from the
samples and their rewards. This one averages the best few samples ("elite averaging").

    python examples/02_custom_optimizer.py
"""

from dataclasses import dataclass

import numpy as np

import judo


@judo.slider("sigma", 0.01, 2.0, 0.01)
@judo.slider("num_best", 1, 32, 1)
@dataclass
class EliteAverageConfig(judo.OptimizerConfig):
    """Elite-averaging settings."""

    sigma: float = 0.3
    """Std of the Gaussian perturbations."""
    num_best: int = 3
    """How many of the best samples are averaged into the new nominal."""


class EliteAverage(judo.Optimizer[EliteAverageConfig]):
    """Perturb the nominal; the new nominal is the mean of the best `num_best` samples."""

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        """(num_nodes, nu) -> (num_rollouts, num_nodes, nu), the nominal first."""
        return self.perturb(nominal_knots, self.config.sigma)

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        """Mean of the `num_best` best (num_nodes, nu) samples."""
        best = np.argsort(-rewards)[: self.config.num_best]
        return sampled_knots[best].mean(axis=0)


def best_reward_after(optimizer_name: str, iterations: int) -> float:
    """Best rollout reward after planning `iterations` times from the hanging-down cart-pole."""
    controller = judo.make_controller("cartpole", optimizer_name, seed=0)
    state = np.array([0.0, np.pi, 0.0, 0.0])
    for _ in range(iterations):
        controller.update_action(state, 0.0)
    controller.close()
    return float(controller.rewards.max())


def main(iterations: int = 10) -> dict[str, float]:
    judo.register_optimizer("elite_average", EliteAverage, EliteAverageConfig)
    results = {name: best_reward_after(name, iterations) for name in ("elite_average", "mppi")}
    for name, reward in results.items():
        print(f"{name:>14}: best reward after {iterations} iterations {reward:9.1f}")
    return results


if __name__ == "__main__":
    main()
