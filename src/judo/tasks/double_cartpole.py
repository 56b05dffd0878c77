"""Double cart-pole swing-up: push a cart so two poles in series swing up from hanging and balance
upright."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.lqr import capped_cost_to_go, lqr_cost_to_go
from judo.core.norms import quadratic_norm, smooth_l1_norm, wrap_angle
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "double_cartpole.xml"
POLE_LENGTH = 0.8
"""Length (m) of each pole; the tip of the upright pair is 2 * POLE_LENGTH above the cart."""
UPRIGHT_TOLERANCE = 0.2
"""Tip distance (m) from straight above the cart within which the poles count as upright in
`metrics`."""
FINAL_WINDOW = 3.0
"""Seconds at the end of an episode over which `metrics` measures the upright fraction."""
RAIL_END_MARGIN = 0.05
"""Distance (m) from the end of the cart's travel within which `metrics` counts the cart as at the
rail's end."""
SOFT_RAIL_MARGIN = 1.0
"""Distance (m) from the end of the cart's travel at which the reward's soft wall (`w_rail_end`)
begins."""
BALANCE_STATE_WEIGHTS = np.array([1.0, 1.0, 1.0, 0.1, 0.1, 0.1])
"""Per-step LQR weights on [cart x (m), lower, upper pole angle (rad), their velocities] behind the
balance cost."""
BALANCE_CONTROL_WEIGHT = 1.0
"""Per-step LQR weight on the squared push behind the balance cost."""
BALANCE_SATURATION = 1000.0
"""LQR cost-to-go at which the balance cost saturates at 1: the cart 2.6 m off centre at rest
upright, or both poles leaning 0.58 rad together with the cart centred; beyond it the linearisation
says little."""


@slider("w_upright", 0.0, 50.0, 0.1)
@slider("w_balance", 0.0, 300.0, 1.0)
@slider("w_centered", 0.0, 20.0, 0.1)
@slider("w_rail_end", 0.0, 500.0, 1.0)
@slider("w_cart_velocity", 0.0, 5.0, 0.01)
@slider("w_velocity", 0.0, 1.0, 0.01)
@slider("w_control", 0.0, 1.0, 0.01)
@dataclass
class DoubleCartpoleConfig(TaskConfig):
    """Double cart-pole reward weights."""

    w_upright: float = 10.0
    """Weight on both poles pointing up (a smooth |angle from vertical| of each pole, in rad)."""
    w_balance: float = 100.0
    """Weight on the balance cost (0 upright and centred at rest, 1 once past recovering). It ranks
    states near the top by how hard they are to bring back, and it is what recentres a balanced
    cart: a 0.8 s horizon cannot see that manoeuvre, which first pushes the cart further out so that
    the poles lean inwards."""
    w_centered: float = 5.0
    """Weight on the cart being at the rail's centre (m)."""
    w_rail_end: float = 100.0
    """Weight on the squared distance (m^2) of the cart past a soft wall 1 m before each end of its
    travel, so that the swing-up does not run the cart into the end stop."""
    w_cart_velocity: float = 0.3
    """Weight on a slow cart (m/s), so the poles do not arrive at the top with the cart racing to
    the rail's end."""
    w_velocity: float = 0.01
    """Weight on small cart and pole velocities."""
    w_control: float = 0.01
    """Weight on small pushes."""


class DoubleCartpole(Task[DoubleCartpoleConfig]):
    """State [cart x, lower pole angle (0 = up), upper pole angle relative to the lower, their
    velocities]; one control, the push on the cart (20 N at 1).

    Needs 40 Hz replanning (`min_control_freq`): upright diverges with a 0.14 s time constant.
    Upright fraction, 5 seeds x 15 s, ps / cem / mppi without latency: 0.94 / 1.0 / 0.99 at 40 Hz,
    0.97 / 0.73 / 0.88 at 30 Hz and 0.59 / 0.41 / 0.76 at 20 Hz (docs/tasks.md).
    """

    measured_sensors = ("slider_pos", "hinge1_pos", "hinge2_pos")
    min_control_freq = 40.0
    lower_is_better = ("final_tip_error", "final_cart_offset", "hit_rail_end")
    focus_body = "cart"

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._tip_column = self.get_sensor_start_index("trace_tip")
        self._cart_travel = float(self.sim_model.jnt_range[self.sim_model.joint("slider").id, 1])
        self.balance_matrix = lqr_cost_to_go(
            self.model, BALANCE_STATE_WEIGHTS, BALANCE_CONTROL_WEIGHT
        )
        """(6, 6) P of the LQR cost-to-go x^T P x around upright and centred, behind
        `balance_cost`."""
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: DoubleCartpoleConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        cart_x, lower, upper = states[..., 0], states[..., 1], states[..., 1] + states[..., 2]
        upright = smooth_l1_norm(wrap_angle(lower)[..., None], 0.1) + smooth_l1_norm(
            wrap_angle(upper)[..., None], 0.1
        )
        past_wall = np.maximum(np.abs(cart_x) - (self._cart_travel - SOFT_RAIL_MARGIN), 0.0)
        return -(
            config.w_upright * upright.sum(-1)
            + config.w_balance * self.balance_cost(states).sum(-1)
            + config.w_centered * smooth_l1_norm(cart_x[..., None], 0.1).sum(-1)
            + config.w_rail_end * np.square(past_wall).sum(-1)
            + config.w_cart_velocity * quadratic_norm(states[..., 3:4]).sum(-1)
            + config.w_velocity * quadratic_norm(states[..., 3:6]).sum(-1)
            + config.w_control * quadratic_norm(controls).sum(-1)
        )

    def balance_cost(self, states: np.ndarray) -> np.ndarray:
        """(...) balance cost of (..., 6) states: the LQR cost-to-go x^T P x around upright and
        centred (pole angles wrapped to [-pi, pi)), divided by BALANCE_SATURATION and capped at
        1."""
        return capped_cost_to_go(
            states[..., :6], self.balance_matrix, BALANCE_SATURATION, angle_columns=[1, 2]
        )

    def reset(self) -> None:
        """Both poles hanging down within 0.2 rad, cart near the centre, small random velocities."""
        self.data.qpos[:] = [0.0, np.pi, 0.0] + self.rng.uniform(-0.2, 0.2, 3)
        self.data.qvel[:] = self.rng.normal(0.0, 0.1, 3)
        mujoco.mj_forward(self.sim_model, self.data)

    def tip_error(self, states: np.ndarray, sensors: np.ndarray) -> np.ndarray:
        """(...,) distance (m) of the tip from its upright spot straight above the cart."""
        tip = sensors[..., self._tip_column : self._tip_column + 3]
        return np.linalg.norm(
            tip - states[..., :1] * [1.0, 0.0, 0.0] - [0.0, 0.0, 2 * POLE_LENGTH], axis=-1
        )

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """upright_fraction: share of the last 3 s with the tip within 0.2 m of straight above the
        cart; final_tip_error (m) and final_cart_offset (m, |x|) at the end; hit_rail_end: 1.0 if
        the cart came within 0.05 m of the end of its travel at any time in the episode (where the
        poles usually fall), else 0.0."""
        error = self.tip_error(log.states, log.sensors)
        final = log.times >= log.times[-1] - FINAL_WINDOW
        return {
            "upright_fraction": float(np.mean(error[final] < UPRIGHT_TOLERANCE)),
            "final_tip_error": float(error[-1]),
            "final_cart_offset": float(abs(log.states[-1, 0])),
            "hit_rail_end": float(
                np.any(np.abs(log.states[:, 0]) > self._cart_travel - RAIL_END_MARGIN)
            ),
        }

    def success(self, metrics: dict[str, float]) -> bool:
        """Success for `collect --success-only`: the tip upright over at least 90% of the final 3 s,
        never near a rail end."""
        return bool(metrics["upright_fraction"] >= 0.9 and metrics["hit_rail_end"] < 0.5)
