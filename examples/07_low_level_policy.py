"""A low-level policy inside every rollout: the MPC plans commands, a policy turns them into ctrl.

This is how a quadruped is planned over its locomotion policy (the MPC plans base velocities, the
policy runs the joints); here on a cart-pole, offline. The policy is a PD law, push = kp (target -
x) - kd x_vel, written as an ONNX file by `write_linear_policy` (no exporter, nothing downloaded)
and loaded with `OnnxPolicy`. The task declares it in `low_level()`: the command (the cart's target
position, within +-1.8 m), the rate (every 2 physics steps, 50 Hz), and how command, state and
previous action make the policy's observation. The optimizer then plans targets; every rollout and
the simulated plant run the policy, the rollouts with one batched `act` per tick for each worker's
block of them. The built-in `cartpole_pd` task is the same.

    PYTHONPATH=src python examples/07_low_level_policy.py [--duration 5]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

import judo
from judo import LowLevel, MujocoSystem
from judo.core.policies.onnx_policy import write_linear_policy
from judo.evaluation.episode import run_episode
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig
from judo.tasks.cartpole import Cartpole

POLICY_FILE = Path(tempfile.mkdtemp(prefix="judo-example-07-")) / "pd.onnx"
# The PD law on [target - x, x_vel]: the observation below.
write_linear_policy(
    POLICY_FILE,
    weight=[[2.0, -0.6]],
    metadata={"name": "cart_pd", "observation": "target - x, x_vel"},
)


def error_and_velocity(
    commands: np.ndarray, states: np.ndarray, previous_actions: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """(B, 2) [target - cart x, cart velocity] from (B, 1) targets and (B, 4) [qpos, qvel] states
    (the previous actions and the (B,) sim times are not needed)."""
    return np.stack([commands[:, 0] - states[:, 0], states[:, 2]], axis=1)


class CartpoleOverPD(Cartpole):
    """Cart-pole swing-up planned in cart targets, through the PD policy."""

    def __init__(self) -> None:
        super().__init__()
        policy = judo.OnnxPolicy(POLICY_FILE)
        self._low_level = LowLevel(
            policy, command_range=[[-1.8, 1.8]], every=2, observation=error_and_velocity
        )

    def low_level(self) -> LowLevel:
        return self._low_level

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        return state[:1].copy()  # the first plan targets the cart where it is


def main(duration: float = 5.0, seed: int = 0) -> dict[str, float]:
    task = CartpoleOverPD()
    task.rng = np.random.default_rng(seed + 1)
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=32, num_nodes=4, sigma=0.5), task.command_size
    )
    optimizer.rng = np.random.default_rng(seed)
    config = judo.ControllerConfig(horizon=1.0, spline_order="cubic", control_freq=50.0)
    with judo.Controller(config, task, optimizer, num_workers=1) as controller:
        result = run_episode(controller, MujocoSystem.from_task(task, seed), duration, seed=seed)
        ticks = controller.backend.act_calls  # type: ignore[attr-defined]
    print(
        f"planned {task.command_size} command(s) for {task.nu} actuator(s); {ticks} batched act "
        "calls in rollouts"
    )
    print(
        f"balanced over the final 3 s: {result.metrics['balanced_fraction']:.2f} (swung up: "
        f"{result.metrics['swung_up']})"
    )
    return result.metrics


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--duration", type=float, default=5.0, help="seconds of sim time")
    main(parser.parse_args().duration)
