"""`FeedbackPlan`: a plan served with the time-varying feedback gains that `FeedbackGains`
(core/feedback.py) computes around its nominal rollout, u(t) = clamp(u_plan(t) + K(t) (x_hat -
x_nom(t))), the deviation taken in the tangent space.
"""

import mujoco
import numpy as np

from judo.core.spline import Spline


class FeedbackPlan(Spline):
    """A plan with time-varying feedback gains: `plan(t, state)` adds K(t) (state - x_nom(t)) to the
    spline.

    Attributes (besides the Spline's):
        gains: (T, nu, 2 nv) gains on the tangent deviation [dq, dv], step k holding for
            [start_time + k dt, start_time + (k + 1) dt); None when this update's gains failed.
        nominal_states: (T, nq + nv) the nominal rollout's [qpos, qvel] at those steps (None with
            gains None).
        feedback_error: why the gains failed (None when they are in force).
    """

    def __init__(
        self,
        plan: Spline,
        model: mujoco.MjModel,
        gains: np.ndarray | None,
        nominal_states: np.ndarray | None,
        feedback_error: str | None = None,
    ) -> None:
        super().__init__(plan.start_time, plan.basis, plan.knots, plan.low, plan.high)
        self.model = model
        self.gains, self.nominal_states, self.feedback_error = gains, nominal_states, feedback_error
        self._dt = float(model.opt.timestep)
        self._nq = model.nq
        self._plain_difference = model.nq == model.nv

    def __call__(self, times: float | np.ndarray, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) for a scalar time, (num_times, nu) for an array of times, within [low, high]. With
        the plant's (nq + nv,) `state` at a scalar time, the gains' correction is added (then
        clamped)."""
        values = super().__call__(times)
        gains, nominal = self.gains, self.nominal_states
        if (
            state is None
            or gains is None
            or nominal is None
            or np.ndim(times) != 0
            or len(state) != len(nominal[0])
        ):
            return values
        step = int((float(times) - self.start_time) / self._dt + 1e-6)
        step = min(max(step, 0), len(gains) - 1)
        x, x_nom, nq = state, nominal[step], self._nq
        if self._plain_difference:
            dx = x - x_nom
        else:
            dq = np.empty(self.model.nv)  # per call: a plan may be served from two threads
            mujoco.mj_differentiatePos(self.model, dq, 1.0, x_nom[:nq], x[:nq])
            dx = np.concatenate([dq, x[nq:] - x_nom[nq:]])
        return np.minimum(np.maximum(values + gains[step] @ dx, self.low), self.high)
