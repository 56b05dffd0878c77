"""Acrobot swing-up: a motor at the elbow alone swings a two-link pendulum upright and balances it."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.fields import slider
from judo.core.norms import quadratic_norm, smooth_l1_norm
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "acrobot.xml"
TOP = np.array([0.0, 0.0, 2.0])
"""Position (m) of the tip when both links point straight up."""
UPRIGHT_TOLERANCE = 0.2
"""Tip distance (m) from the top within which the acrobot counts as upright in `metrics`."""
FINAL_WINDOW = 3.0
"""Seconds at the end of an episode over which `metrics` measures the upright fraction."""


@slider("w_tip", 0.0, 50.0, 0.1)
@slider("w_energy", 0.0, 10.0, 0.01)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.01)
@dataclass
class AcrobotConfig(TaskConfig):
    """Acrobot reward weights."""

    w_tip: float = 10.0
    """Weight on the tip's distance (m) from the top."""
    w_energy: float = 1.0
    """Weight on the total energy (J) differing from that of resting upright; it drives the pumping
    that a 1 s horizon cannot see the pay-off of."""
    w_velocity: float = 0.02
    """Weight on slow joints; too much of it stops the pumping that the swing-up needs."""
    w_control: float = 0.01
    """Weight on small elbow torques."""


class Acrobot(Task[AcrobotConfig]):
    """State [shoulder, elbow angles (0, 0 = straight up), their velocities]; one control, the elbow
    torque (5 Nm at 1). The shoulder is unactuated."""

    def __init__(self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None) -> None:
        super().__init__(model_path, sim_model_path)
        self._tip_column = self.get_sensor_start_index("trace_tip")
        self._potential_column = self.get_sensor_start_index("potential_energy")
        self._kinetic_column = self.get_sensor_start_index("kinetic_energy")
        upright = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, upright)
        self.upright_energy = float(upright.sensordata[self._potential_column])
        """Potential energy (J) of the links resting straight up: the energy a swing-up aims for."""
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: AcrobotConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        tip = sensors[..., self._tip_column : self._tip_column + 3]
        energy = sensors[..., self._potential_column] + sensors[..., self._kinetic_column]
        return -(
            config.w_tip * smooth_l1_norm(tip - TOP, 0.1).sum(-1)
            + config.w_energy * np.abs(energy - self.upright_energy).sum(-1)
            + config.w_velocity * quadratic_norm(states[..., 2:4]).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def reset(self) -> None:
        """Both links hanging down within 0.2 rad, with small random velocities."""
        self.data.qpos[:] = [np.pi, 0.0] + self.rng.uniform(-0.2, 0.2, 2)
        self.data.qvel[:] = self.rng.normal(0.0, 0.1, 2)
        mujoco.mj_forward(self.sim_model, self.data)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """upright_fraction: share of the last 3 s with the tip within 0.2 m of the top;
        final_tip_distance: the tip's distance (m) from the top at the end."""
        distance = np.linalg.norm(log.sensors[:, self._tip_column : self._tip_column + 3] - TOP, axis=-1)
        final = log.times >= log.times[-1] - FINAL_WINDOW
        return {
            "upright_fraction": float(np.mean(distance[final] < UPRIGHT_TOLERANCE)),
            "final_tip_distance": float(distance[-1]),
        }
