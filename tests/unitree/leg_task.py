"""A registered task on one Go2-like leg (tests/unitree/leg.xml), for the Unitree link's tests:
`python -m judo plant` runs it as a robot process through `python leg_task.py plant ...`, and the
bridge drives it in the tests."""

import sys
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.configuration.registry import register_task
from judo.core.task import Task, TaskConfig

MODEL = Path(__file__).with_name("leg.xml")
JOINTS = ("FR_hip_joint", "FR_thigh_joint", "FR_calf_joint")
STAND = np.array([0.0, 0.67, -1.3])
"""The leg's pose standing (Unitree's Go2 stand-up pose)."""


class UnitreeLeg(Task[TaskConfig]):
    """Hold the leg at `STAND`."""

    measured_sensors = (
        *(f"{j}_pos" for j in JOINTS),
        *(f"{j}_vel" for j in JOINTS),
        "imu_quat",
        "imu_gyro",
        "imu_acc",
        "foot_force_FR",
    )

    def __init__(self) -> None:
        super().__init__(MODEL)
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: TaskConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        return -np.square(states[..., :3] - STAND).sum(axis=(-1, -2))


register_task("unitree_leg", UnitreeLeg, TaskConfig)

# python leg_task.py plant ARGS: the plant command with this task registered
if __name__ == "__main__":
    from judo.unitree.robot import main

    sys.exit(main(sys.argv[2:]))
