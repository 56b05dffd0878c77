"""The quadruped walks to goals planned over a locomotion policy judo taught itself.

judo's CEM taught a gait policy to follow a base-velocity command on `quadruped_velocity`'s reward,
the objective its MPC plans with (`python -m judo gait-search`, docs/tasks.md); it ships as
models/policies/quadruped_locomotion.onnx. `quadruped_navigate` plans only the command [vx, vy, yaw
rate] with 3 knots over 1 s, with a quarter of quadruped's rollouts: inside every rollout the policy
turns the command into the joint targets at 50 Hz, batched over each worker's rollouts, and the
plant runs the same policy on the command it is served, as a robot's onboard controller would. Its
policy runs on onnxruntime, a core dependency.

    PYTHONPATH=src python examples/09_quadruped_navigate.py [--duration 10]
    python -m judo --task quadruped_navigate --optimizer mppi    # the GUI: drag the goal disc around
"""  # noqa: E501

import argparse

import numpy as np

import judo
from judo import MujocoSystem
from judo.evaluation.episode import run_episode


def main(duration: float = 10.0, seed: int = 0) -> dict[str, float]:
    """Walk to goals for `duration` s of sim time with MPPI over the policy; returns the episode's
    metrics."""
    controller = judo.make_controller("quadruped_navigate", "mppi", seed=seed, num_workers=2)
    # the plant runs the policy on the served command
    plant = MujocoSystem.from_task(controller.task, seed)
    with controller:
        result = run_episode(controller, plant, duration, seed=seed)
    metrics, policy = result.metrics, controller.task.low_level().policy
    print(
        f"over {policy.name!r}, {duration:g} s: {metrics['goals_reached']:.0f} goals "
        f"({metrics['goals_per_minute']:.1f} a minute), {metrics['falls']:.0f} falls, "
        f"{metrics['final_distance']:.2f} m from the last goal; median update "
        f"{np.median(result.update_ms):.0f} ms"
    )
    return metrics


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    main(args.duration, args.seed)
