"""A quadruped planned directly in its 12 joint targets: walk to goals, or follow a velocity
command.

The built-in `quadruped` task puts a Go1-class robot (12 kg, 0.213 m thigh and calf, position servos
at the Go1's torque limits; models/quadruped.xml, built from primitives) on a floor with a goal
disc. Every update the optimizer samples joint-target splines around its last plan, starting from
the standing pose, and the reward
(after MJPC's quadruped) asks for the trunk's height and uprightness, walking towards the goal while
facing it, feet lifted on a trot schedule read off the model's clock sensor, and little effort. Once
the trunk is within 0.25 m of the goal, the plant draws a new goal 1 to 2 m
away. `quadruped_velocity` is the same robot following a command [vx, vy, yaw rate] redrawn every 4
s; set `manual` to steer it yourself.

    PYTHONPATH=src python examples/08_quadruped.py [--duration 10] [--gait walk]
    python -m judo --task quadruped --optimizer mppi    # the GUI: drag the goal disc around
"""

import argparse

import numpy as np

import judo
from judo import MujocoSystem
from judo.evaluation.episode import run_episode


def main(duration: float = 10.0, seed: int = 0, gait: str = "trot") -> dict[str, float]:
    """Walk to goals for `duration` s of sim time with MPPI and the task's defaults; returns the
    episode's metrics."""
    controller = judo.make_controller("quadruped", "mppi", seed=seed, num_workers=2)
    controller.task.config.gait = gait  # "trot", "walk" or "stand"
    # shares the config: the plant's goals follow it too
    plant = MujocoSystem.from_task(controller.task, seed)
    with controller:
        result = run_episode(controller, plant, duration, seed=seed)
    metrics = result.metrics
    print(
        f"{gait}, {duration:g} s: {metrics['goals_reached']:.0f} goals "
        f"({metrics['goals_per_minute']:.1f} a minute), "
        f"{metrics['falls']:.0f} falls, {metrics['final_distance']:.2f} m from the last goal; "
        f"median update {np.median(result.update_ms):.0f} ms"
    )
    return metrics


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--gait", choices=("trot", "walk", "stand"), default="trot")
    args = parser.parse_args()
    main(args.duration, args.seed, args.gait)
