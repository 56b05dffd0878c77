"""01: write a task, register it, and run it in a closed loop.

The task drives a point mass on a table to a goal. Its reward reads weights and the goal from the
config snapshot it is given; `register_task` makes it available to `make_controller`, the GUI's
dropdown and `python -m judo --task reach`.

    python examples/01_custom_task.py
"""

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import judo
from judo import MujocoSystem

REACH_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body name="mass" pos="0 0 0.05">
      <joint name="x" type="slide" axis="1 0 0" damping="0.5"/>
      <joint name="y" type="slide" axis="0 1 0" damping="0.5"/>
      <geom type="sphere" size="0.05" mass="0.1" contype="0" conaffinity="0"/>
      <site name="center"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="x" ctrlrange="-1 1"/>
    <motor joint="y" ctrlrange="-1 1"/>
  </actuator>
  <sensor><framepos name="trace_mass" objtype="site" objname="center"/></sensor>
</mujoco>
"""
MODEL_PATH = Path(tempfile.mkdtemp()) / "reach.xml"
MODEL_PATH.write_text(REACH_XML)


@judo.slider("w_position", 0.0, 10.0, 0.1)
@dataclass
class ReachConfig(judo.TaskConfig):
    """Reach-task weights and goal."""

    w_position: float = 1.0
    """Weight on being at the goal."""
    w_control: float = 0.01
    """Weight on small forces."""
    goal: np.ndarray = judo.np_1d_field(np.array([0.3, -0.2]), names=["x", "y"], vis_name="goal")
    """Goal position (m)."""


class Reach(judo.Task[ReachConfig]):
    """Drive a point mass to a goal. State: x, y, and velocities (4,); actions: x, y forces (2,)."""

    def __init__(self, model_path: Path = MODEL_PATH, sim_model_path: Path | None = None) -> None:
        super().__init__(model_path, sim_model_path)
        self.reset()

    def reward(self, states, sensors, controls, config, system_metadata=None):
        """(num_rollouts, T, 4) states and (num_rollouts, T, 2) controls -> (num_rollouts,)
        rewards."""
        to_goal = judo.quadratic_norm(states[..., 0:2] - config.goal).sum(-1)
        return -config.w_position * to_goal - config.w_control * judo.quadratic_norm(controls).sum(
            -1
        )

    def reset(self) -> None:
        self.data.qpos[:] = self.rng.uniform(-0.4, 0.4, 2)
        self.data.qvel[:] = 0.0


def main(duration: float = 3.0) -> float:
    """Run `duration` seconds of closed loop; return the final distance to the goal (m)."""
    judo.register_task("reach", Reach, ReachConfig)
    judo.set_config_overrides("reach", judo.OptimizerConfig, {"num_rollouts": 16})
    with judo.make_controller("reach", "mppi", seed=0) as controller:
        # a second Reach instance is the plant
        plant = MujocoSystem.from_task(controller.task, seed=0)
        loop = judo.ClosedLoop(controller, plant)  # read, plan, serve, step: the loop the app runs
        loop.restart()
        while loop.reading.time < duration:
            loop.step()
    distance = float(np.linalg.norm(plant.task.data.qpos[:2] - plant.task.config.goal))
    print(f"distance to goal after {duration:.0f} s: {distance:.3f} m")
    return distance


if __name__ == "__main__":
    main()
