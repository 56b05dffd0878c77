"""12: a task on your own dynamics, no MJCF: a unicycle drives around a round obstacle to a goal.

`judo.DynamicsTask` takes the state's length, the control limits and the step; `dynamics` steps a
batch of states in numpy. The Controller rolls it out in T vectorized calls and the plant steps the
same equations (judo.core.rollouts.dynamics), so the rest of judo (optimizers, evaluate, tune, the
GUI) is unchanged.

    python examples/12_own_dynamics.py
"""

from dataclasses import dataclass

import numpy as np

import judo
from judo.optimizers.mppi import MPPIConfig

GOAL = np.array([2.0, 0.0])
OBSTACLE, RADIUS = np.array([1.0, 0.2]), 0.3


@dataclass
class UnicycleConfig(judo.TaskConfig):
    """Unicycle weights."""

    w_goal: float = 1.0
    """Weight on the distance (m) to the goal."""
    w_obstacle: float = 50.0
    """Weight on how deep (m) the unicycle is inside the obstacle (plus 10 cm)."""


class Unicycle(judo.DynamicsTask[UnicycleConfig]):
    """State [x, y, heading] (nx = 3); controls [forward speed (m/s), turn rate (rad/s)], each
    within +-1."""

    def __init__(self) -> None:
        super().__init__(nx=3, control_range=[[-1.0, 1.0], [-1.0, 1.0]], dt=0.05)

    def dynamics(self, states: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
        x, y, heading = states.T
        speed, turn = controls.T
        return np.stack(
            [
                x + dt * speed * np.cos(heading),
                y + dt * speed * np.sin(heading),
                heading + dt * turn,
            ],
            1,
        )

    def reward(self, states, sensors, controls, config, system_metadata=None):
        """(N, T, 4) states (x, y, heading and a zero: nx is odd) -> (N,) rewards."""
        position = states[..., :2]
        inside = np.maximum(RADIUS + 0.1 - np.linalg.norm(position - OBSTACLE, axis=-1), 0.0)
        return -(
            config.w_goal * np.linalg.norm(position - GOAL, axis=-1) + config.w_obstacle * inside
        ).sum(-1)


def main(duration: float = 8.0) -> dict[str, float]:
    """Drive `duration` seconds in closed loop; return the final distance to the goal and the
    closest approach to the obstacle's centre (m)."""
    judo.register_task("unicycle", Unicycle, UnicycleConfig)
    judo.set_config_overrides(
        "unicycle", judo.ControllerConfig, {"horizon": 2.0, "spline_order": "cubic"}
    )
    judo.set_config_overrides("unicycle", MPPIConfig, {"sigma": 0.5})
    with judo.make_controller("unicycle", "mppi", seed=0) as controller:
        # a DynamicsSystem stepping `dynamics`
        plant = judo.MujocoSystem.from_task(controller.task, seed=0)
        unicycle = plant.task
        assert isinstance(unicycle, Unicycle)
        loop = judo.ClosedLoop(controller, plant)
        loop.restart()
        closest = np.inf
        while loop.reading.time < duration:
            loop.step()
            closest = min(closest, float(np.linalg.norm(unicycle.state[:2] - OBSTACLE)))
    result = {
        "final_distance": float(np.linalg.norm(unicycle.state[:2] - GOAL)),
        "closest_approach": closest,
    }
    print(
        f"after {duration:.0f} s: {result['final_distance']:.2f} m from the goal, never "
        "nearer than "
        f"{closest:.2f} m to the obstacle's centre (radius {RADIUS} m)"
    )
    return result


if __name__ == "__main__":
    main()
