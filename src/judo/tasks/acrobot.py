"""Acrobot swing-up: a motor at the elbow alone swings a two-link pendulum upright and balances
it."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.lqr import capped_cost_to_go, lqr_cost_to_go
from judo.core.norms import quadratic_norm, smooth_l1_norm
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "acrobot.xml"
TOP = np.array([0.0, 0.0, 2.0])
"""Position (m) of the tip when both links point straight up."""
BALANCE_STATE_WEIGHTS = np.array([1.0, 1.0, 0.1, 0.1])
"""Per-step LQR weights on [shoulder, elbow angle (rad), their velocities (rad/s)] behind the
balance cost."""
BALANCE_CONTROL_WEIGHT = 1.0
"""Per-step LQR weight on the squared control behind the balance cost."""
BALANCE_SATURATION = 1000.0
"""LQR cost-to-go at which the balance cost saturates at 1: a 0.09 rad lean of both links at rest,
past the lean (between 0.02 and 0.05 rad) from which that LQR with 5 Nm brings them back; further
off, states look alike."""
UPRIGHT_TOLERANCE = 0.2
"""Tip distance (m) from the top within which the acrobot counts as upright in `metrics`."""
FINAL_WINDOW = 3.0
"""Seconds at the end of an episode over which `metrics` measures the upright fraction."""


@slider("w_tip", 0.0, 50.0, 0.1)
@slider("w_energy", 0.0, 10.0, 0.01)
@slider("w_balance", 0.0, 100.0, 0.1)
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
    w_balance: float = 20.0
    """Weight on the balance cost (0 upright at rest, 1 once past recovering): it ranks the states
    near the top by how hard they are to bring back, which the tip's distance alone does not."""
    w_velocity: float = 0.02
    """Weight on slow joints; too much of it stops the pumping that the swing-up needs."""
    w_control: float = 0.01
    """Weight on small elbow torques."""


@dataclass(frozen=True)
class AcrobotEnergy:
    """The acrobot's energy as a function of its state, with coefficients read from the model.

    With angles q1 (shoulder), q2 (elbow) from straight up and velocities v1, v2:
    kinetic = 0.5 [(a + 2b cos q2) v1^2 + 2 (c + b cos q2) v1 v2 + c v2^2] (the mass matrix depends
    on the elbow alone), potential = g1 cos q1 + g2 cos(q1 + q2) (J, zero with the links level with
    the shoulder).
    """

    a: float
    b: float
    c: float
    g1: float
    g2: float

    @classmethod
    def of_model(cls, model: mujoco.MjModel) -> "AcrobotEnergy":
        """Read the coefficients from `model` at two poses: elbow bent 90 degrees and straight."""
        data = mujoco.MjData(model)
        mass_matrices, potentials = [], []
        for elbow in (np.pi / 2, 0.0):
            data.qpos[:] = [0.0, elbow]
            mujoco.mj_forward(model, data)
            matrix = np.zeros((model.nv, model.nv))
            mujoco.mj_fullM(model, data, matrix)
            mass_matrices.append(matrix)
            potentials.append(
                -float(model.opt.gravity[2]) * float(model.body_mass @ data.xipos[:, 2])
            )
        bent, straight = mass_matrices
        # Bent at 90 degrees the lower link lies level with the elbow: its cos(q1 + q2) term is
        # zero.
        bent_potential, straight_potential = potentials
        return cls(
            a=float(bent[0, 0]),
            b=float(straight[0, 1] - bent[0, 1]),
            c=float(bent[1, 1]),
            g1=bent_potential,
            g2=straight_potential - bent_potential,
        )

    def total(self, states: np.ndarray) -> np.ndarray:
        """Kinetic plus potential energy (J) of (..., 4) states [q1, q2, v1, v2] -> (...)."""
        shoulder, elbow, v1, v2 = np.moveaxis(states[..., :4], -1, 0)
        cos_elbow = np.cos(elbow)
        kinetic = 0.5 * (
            (self.a + 2 * self.b * cos_elbow) * v1**2
            + 2 * (self.c + self.b * cos_elbow) * v1 * v2
            + self.c * v2**2
        )
        return kinetic + self.g1 * np.cos(shoulder) + self.g2 * np.cos(shoulder + elbow)


class Acrobot(Task[AcrobotConfig]):
    """State [shoulder, elbow angles (0, 0 = straight up), their velocities]; one control, the elbow
    torque (5 Nm at 1). The shoulder is unactuated.

    Needs 50 Hz replanning (`min_control_freq`): upright diverges with a 0.15 s time constant and
    only the elbow pushes back. Upright fraction, 5 seeds x 15 s, ps / cem / mppi: 0.89 / 0.94 /
    0.92 at 50 Hz, 0.85 / 0.74 / 0.78 at 40 Hz and 0.80 / 0.72 / 0.79 at 20 Hz (docs/tasks.md).
    """

    measured_sensors = ("shoulder_pos", "elbow_pos")
    min_control_freq = 50.0
    lower_is_better = ("final_tip_distance",)
    focus_body = "upper_arm"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._tip_column = self.get_sensor_start_index("trace_tip")
        self.energy = AcrobotEnergy.of_model(self.model)
        """Energy of a state, computed from the state itself: MuJoCo's e_kinetic sensor holds the
        value of the previous evaluation, which in a rollout's first step belongs to an unrelated
        rollout."""
        self.upright_energy = self.energy.g1 + self.energy.g2
        """Energy (J) of the links resting straight up: the energy a swing-up aims for."""
        self.balance_matrix = lqr_cost_to_go(
            self.model, BALANCE_STATE_WEIGHTS, BALANCE_CONTROL_WEIGHT
        )
        """(4, 4) P of the LQR cost-to-go x^T P x around upright, behind `balance_cost`."""
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
        energy = self.energy.total(states)
        return -(
            config.w_tip * smooth_l1_norm(tip - TOP, 0.1).sum(-1)
            + config.w_energy * np.abs(energy - self.upright_energy).sum(-1)
            + config.w_balance * self.balance_cost(states).sum(-1)
            + config.w_velocity * quadratic_norm(states[..., 2:4]).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def balance_cost(self, states: np.ndarray) -> np.ndarray:
        """(...) balance cost of (..., 4) states: the LQR cost-to-go x^T P x around upright (angles
        wrapped to [-pi, pi)), divided by BALANCE_SATURATION and capped at 1."""
        return capped_cost_to_go(
            states[..., :4], self.balance_matrix, BALANCE_SATURATION, angle_columns=[0, 1]
        )

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, 6) [cos shoulder, cos elbow, sin shoulder, sin elbow, shoulder rate, elbow rate] of (B, 4) states.

        Both hinges are unlimited: a swing-up that goes over the top leaves the raw angles at 2 pi,
        4 pi, ... for the same pose, which a learned policy would have to meet in its data at every
        one of them; cos and sin are the same there.
        """  # noqa: E501
        states = np.asarray(states, dtype=float)
        return np.concatenate(
            [np.cos(states[:, :2]), np.sin(states[:, :2]), states[:, 2:4]], axis=1
        )

    def reset(self) -> None:
        """Both links hanging down within 0.2 rad, with small random velocities."""
        self.data.qpos[:] = [np.pi, 0.0] + self.rng.uniform(-0.2, 0.2, 2)
        self.data.qvel[:] = self.rng.normal(0.0, 0.1, 2)
        mujoco.mj_forward(self.sim_model, self.data)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """upright_fraction: share of the last 3 s with the tip within 0.2 m of the top;
        final_tip_distance: the tip's distance (m) from the top at the end."""
        distance = np.linalg.norm(
            log.sensors[:, self._tip_column : self._tip_column + 3] - TOP, axis=-1
        )
        final = log.times >= log.times[-1] - FINAL_WINDOW
        return {
            "upright_fraction": float(np.mean(distance[final] < UPRIGHT_TOLERANCE)),
            "final_tip_distance": float(distance[-1]),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: the tip upright over at least 90% of the final 3
        s."""
        return bool(metrics["upright_fraction"] >= 0.9)
