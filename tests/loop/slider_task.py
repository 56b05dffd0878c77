"""The loop tests' plant: a block on a rail with a position actuator, whose reward wants the block
at 0.5."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judo.core.task import Task, TaskConfig

SLIDER_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="block">
      <joint name="x" type="slide" axis="1 0 0" damping="1"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
  </worldbody>
  <actuator><position joint="x" kp="10" ctrlrange="-2 2" ctrllimited="true"/></actuator>
  <sensor><jointpos name="x_pos" joint="x"/></sensor>
</mujoco>
"""


@dataclass
class HoldConfig(TaskConfig):
    """No settings."""


def hold_base(folder: Path) -> type[Task[HoldConfig]]:
    """A Task class on SLIDER_XML (written into `folder`) with the hold reward; each test file adds
    its reset."""
    path = folder / "slider.xml"
    path.write_text(SLIDER_XML)

    class HoldBase(Task[HoldConfig]):
        def __init__(self):
            super().__init__(path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return -np.abs(states[..., 0] - 0.5).sum(-1)

    return HoldBase
