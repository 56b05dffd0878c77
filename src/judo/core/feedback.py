"""Feedback gains on the served plan: a time-varying LQR around the nominal plan's rollout.

Between two control updates the plan is served open-loop, `u(t)` from the spline, whatever the state
does. With `ControllerConfig.feedback`, each update also linearises the planning model along the
nominal plan's rollout (`mujoco.mjd_transitionFD` at up to 20 evenly spaced steps, on the CPU worker
threads, one MjData each) and runs a time-varying LQR backward pass on a quadratic tracking cost;
the plan (`FeedbackPlan`, core/feedback_plan.py) carries the gains and serves

    u(t) = clamp(u_plan(t) + K(t) (x_hat - x_nom(t)))

with x_hat the reading (or the estimate) and x_nom(t) the nominal rollout's state, their difference
taken in the tangent space (`mj_differentiatePos`: a free joint's quaternion deviation is a
3-vector).

The cost is a tracking cost, Q = diag(state weights) on the tangent deviation and R = diag(control
weights), from the task's `feedback_cost` hook (`Task.feedback_cost`), not a quadratic expansion of
the task's reward: the planner already optimised the reward, and what the gains must do between
replans is hold the plant to the plan it scored. A finite-difference Hessian of a sampling reward is
often indefinite or zero (capped and piecewise terms) and needs O(n^2) extra reward calls with their
sensors per step; a diagonal tracking cost is positive definite, costs nothing, and is what TVLQR
tracking controllers on hardware use.
"""

import math
import os
import typing

import mujoco
import mujoco.rollout
import numpy as np

from judo.core.errors import JudoError
from judo.core.feedback_plan import FeedbackPlan
from judo.core.model import STATE_SPEC
from judo.core.rollouts.rollout import DaemonThreadPool
from judo.core.spline import Spline

if typing.TYPE_CHECKING:
    from judo.core.task import Task

FD_EPS = 1e-6
"""Finite-difference step of `mjd_transitionFD` (MuJoCo's own default); forward differences."""
MAX_LINEARISATIONS = 20
"""Most steps of the nominal rollout that are linearised: every ceil(T / L)-th step, each
linearisation standing for the steps up to the next (`tvlqr_gains`). A linearisation costs 2 nv + na
+ nu + 1 model steps; along all T steps they would cost about as much as the rollouts themselves."""
MIN_LINEARISATIONS = 4
"""Fewest steps linearised, whatever the budget."""
LINEARISATION_SHARE = 0.15
"""The gains' budget: their linearisations may cost this share of the model steps of one update's
rollouts."""
SERVED_PERIODS = 2
"""Control periods from a plan's start with exact per-step gains (a plan is served for about one;
the watchdog keeps an older one at most max_plan_age); the gains beyond are held per linearisation
(`tvlqr_gains`)."""
MAX_GAIN = 1e6
"""Largest |K| entry accepted; larger gains mean a degenerate linearisation and the plan is served
without."""


class FeedbackError(JudoError):
    """The gains of one update could not be computed (non-finite derivatives or gains): its plan is
    served without gains."""


def tvlqr_gains(
    a: np.ndarray,
    b: np.ndarray,
    state_weights: np.ndarray,
    control_weights: np.ndarray,
    final_weights: np.ndarray,
    source: np.ndarray | None = None,
    exact_steps: int | None = None,
) -> np.ndarray:
    """(T, m, n) feedback gains K_t of the finite-horizon time-varying LQR, du_t = K_t dx_t.

    Minimises sum_t (dx_t' Q dx_t + du_t' R du_t) + dx_T' Q_f dx_T subject to dx_{t+1} = A_t dx_t +
    B_t du_t, with Q, R and Q_f the diagonals `state_weights` (n,), `control_weights` (m,) and
    `final_weights` (n,); `a` is (L, n, n), `b` is (L, n, m) and step t uses linearisation
    `source[t]` ((T,) nondecreasing ints; by default t itself, T = L).

    The first `exact_steps` steps (all by default) get the exact per-step recursion. Beyond them,
    the steps of one linearisation share one gain, designed for a correction held over them: the
    backward pass takes their s-step map dx -> A^s dx + (I + A + ... + A^(s-1)) B du at s times the
    running cost, once per linearisation instead of once per step. A plan is served only until the
    next one takes effect, so the held gains are rarely served; they carry the cost-to-go back to
    the exact ones. Raises FeedbackError when a gain is not finite or the recursion is singular.
    """
    source = np.arange(len(a)) if source is None else np.asarray(source)
    num_steps, n, m = len(source), b.shape[1], b.shape[2]
    exact = num_steps if exact_steps is None else min(max(exact_steps, 0), num_steps)
    # segments (linearisation, steps) from the end: one per linearisation in the tail, one per step
    # before it
    tail = source[exact:]
    starts = (
        np.flatnonzero(np.r_[True, tail[1:] != tail[:-1]]) if len(tail) else np.zeros(0, dtype=int)
    )
    counts = np.diff(np.r_[starts, len(tail)])
    segments = [(int(tail[k]), int(c)) for k, c in zip(starts, counts, strict=True)]
    segments = [(int(source[t]), 1) for t in range(exact)] + segments
    with np.errstate(over="ignore", invalid="ignore"):
        longest = max((c for _, c in segments), default=1)
        # lifted[c - 1]: (L, n, n + m) [A^c, (I + ... + A^(c-1)) B]
        lifted = [np.concatenate([a, b], axis=2)]
        power, total = a, b
        for _ in range(1, longest):
            total = total + power @ b
            power = power @ a
            lifted.append(np.concatenate([power, total], axis=2))
        q, r = np.diag(state_weights), np.diag(control_weights)
        p = np.diag(final_weights).astype(float)
        gains = np.empty((num_steps, m, n))
        end = num_steps
        try:
            for point, count in reversed(segments):
                ab = lifted[count - 1][point]
                h = ab.T @ (p @ ab)  # [[A'PA, A'PB], [B'PA, B'PB]]
                k = np.linalg.solve(count * r + h[n:, n:], h[n:, :n])
                gains[end - count : end] = -k
                end -= count
                p = count * q + h[:n, :n] - h[:n, n:] @ k  # sQ + A'P(A - BK)
                p = 0.5 * (p + p.T)
        except np.linalg.LinAlgError as err:
            raise FeedbackError(f"the LQR backward pass is singular ({err})") from None
    if not np.isfinite(gains).all():
        raise FeedbackError("the LQR backward pass gave non-finite gains")
    return gains


class FeedbackGains:
    """Linearises the planning model along a nominal control sequence and computes its TVLQR gains.

    Owns one MjData per worker thread and its buffers (reallocated only when the horizon changes).
    The linearised steps (`num_points`, at most MAX_LINEARISATIONS) are split into one contiguous
    chunk per worker; `mjd_transitionFD` releases the GIL, so the chunks run in parallel.

    Args:
        task: the task whose planning model (never modified) is linearised and whose `feedback_cost`
            weighs the deviations (only `compute` works without one: None).
        num_workers: threads for the derivatives (the rollout pool's count; one per core by
            default).
    """

    def __init__(
        self,
        task: "Task | None",
        num_workers: int | None = None,
        model: mujoco.MjModel | None = None,
    ) -> None:
        self.task = task
        model = model if model is not None else task.model if task is not None else None
        if model is None:
            raise ValueError("FeedbackGains needs a task or a model")
        self.model = model
        self.num_workers = max(1, num_workers or os.cpu_count() or 1)
        self._datas: list[mujoco.MjData] = []  # one per worker, made with the first gains
        self._executor = DaemonThreadPool(self.num_workers, "judo-feedback")
        self._runner = mujoco.rollout.Rollout(nthread=0)
        self.nstate = mujoco.mj_stateSize(model, STATE_SPEC)
        self.ndx = 2 * model.nv + model.na
        self._layout = (-1, -1)

    def num_points(self, num_steps: int, num_rollouts: int | None) -> int:
        """Steps to linearise along a T = `num_steps` rollout: MAX_LINEARISATIONS for `num_rollouts`
        None, else as many as LINEARISATION_SHARE of `num_rollouts` x T model steps pay for
        (MIN_LINEARISATIONS at least), rounded down to a multiple of the workers, who share them."""
        if num_rollouts is None:
            return min(MAX_LINEARISATIONS, num_steps)
        affordable = int(
            LINEARISATION_SHARE * num_rollouts * num_steps / (self.ndx + self.model.nu + 1)
        )
        if affordable > self.num_workers:
            affordable -= affordable % self.num_workers
        return min(max(affordable, MIN_LINEARISATIONS), MAX_LINEARISATIONS, num_steps)

    def _allocate(self, num_steps: int, max_points: int) -> None:
        model = self.model
        self._datas = self._datas or [mujoco.MjData(model) for _ in range(self.num_workers)]
        self._layout = (num_steps, max_points)
        self._states = np.zeros((1, num_steps, self.nstate))
        self._sensors = np.zeros((1, num_steps, model.nsensordata))
        self._inputs = np.zeros((1, num_steps, model.nu + 7 * model.nmocap))
        stride = math.ceil(num_steps / max_points)
        self.points = np.arange(0, num_steps, stride)  # the steps linearised
        self.source = np.arange(num_steps) // stride  # the linearisation each step uses
        num_points = len(self.points)
        self._a = np.zeros((num_points, self.ndx, self.ndx))
        self._b = np.zeros((num_points, self.ndx, model.nu))
        bounds = np.linspace(0, num_points, min(self.num_workers, num_points) + 1).astype(int)
        self._chunks = [range(lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)]

    def linearise(
        self,
        initial_state: np.ndarray,
        mocap: np.ndarray,
        controls: np.ndarray,
        max_points: int = MAX_LINEARISATIONS,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The nominal rollout of the (T, nu) `controls` from the (nstate,) `initial_state`
        (STATE_SPEC) with the (7 nmocap,) `mocap` poses held, and its linearisations at up to
        `max_points` steps.

        Returns (T, nstate) states before each step's control (STATE_SPEC), and (L, n, n) A and (L,
        n, nu) B (n = 2 nv + na) at the L steps `points` (L,); step t uses linearisation `source[t]`
        ((T,) ints). The arrays are reused by the next call. Raises FeedbackError for a diverged
        rollout or non-finite derivatives.
        """
        model, nu = self.model, self.model.nu
        num_steps = len(controls)
        if (num_steps, max_points) != self._layout:
            self._allocate(num_steps, max_points)
        self._inputs[0, :, :nu] = controls
        self._inputs[0, :, nu:] = mocap
        spec = mujoco.mjtState.mjSTATE_CTRL
        if model.nmocap:
            spec |= mujoco.mjtState.mjSTATE_MOCAP_POS | mujoco.mjtState.mjSTATE_MOCAP_QUAT
        states = self._states
        states[0, 0] = initial_state
        if num_steps > 1:
            self._runner.rollout(
                [model],
                [self._datas[0]],
                initial_state[None],
                self._inputs[:, :-1],
                control_spec=int(spec),
                skip_checks=True,
                nstep=num_steps - 1,
                state=states[:, 1:],
                sensordata=self._sensors[:, : num_steps - 1],
            )
        path = states[0]
        if not np.isfinite(path).all():
            raise FeedbackError("the nominal rollout diverged")
        a, b = self._a, self._b

        def linearise(worker: int) -> None:
            data = self._datas[worker]
            mujoco.mj_resetData(model, data)
            if model.nmocap:
                data.mocap_pos[:] = mocap[: 3 * model.nmocap].reshape(-1, 3)
                data.mocap_quat[:] = mocap[3 * model.nmocap :].reshape(-1, 4)
            for i in self._chunks[worker]:
                k = self.points[i]
                mujoco.mj_setState(model, data, path[k], STATE_SPEC)
                data.ctrl[:] = controls[k]
                mujoco.mjd_transitionFD(model, data, FD_EPS, False, a[i], b[i], None, None)

        futures = [self._executor.submit(linearise, w) for w in range(1, len(self._chunks))]
        try:
            linearise(0)
        finally:
            for future in futures:
                future.exception()
        for future in futures:
            future.result()
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            bad = self.points[
                np.flatnonzero(
                    ~(np.isfinite(a).all(axis=(1, 2)) & np.isfinite(b).all(axis=(1, 2)))
                )[0]
            ]
            raise FeedbackError(f"non-finite derivatives at step {bad} of the nominal rollout")
        return path, a, b

    def compute(
        self,
        initial_state: np.ndarray,
        mocap: np.ndarray,
        controls: np.ndarray,
        state_weights: np.ndarray,
        control_weights: np.ndarray,
        max_points: int = MAX_LINEARISATIONS,
        exact_steps: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Gains and nominal states of the (T, nu) `controls` rolled out from the (nstate,)
        `initial_state` (STATE_SPEC) with the (7 nmocap,) `mocap` poses held.

        Args:
            state_weights: (2 nv,) Q on [dq, dv]; control_weights: (nu,) R.
            max_points: most steps linearised (see `linearise`).
            exact_steps: steps from the start with exact per-step gains (all by default;
                `tvlqr_gains`).
        Returns:
            (T, nu, 2 nv) gains and the (T, nq + nv) nominal [qpos, qvel] at steps 0..T-1.
        Raises FeedbackError for non-finite states, derivatives or gains, or gains beyond MAX_GAIN.
        """
        model, nq, nv = self.model, self.model.nq, self.model.nv
        path, a, b = self.linearise(initial_state, mocap, controls, max_points)
        weights = np.concatenate([state_weights, np.full(model.na, 1e-6)])
        gains = tvlqr_gains(a, b, weights, control_weights, weights, self.source, exact_steps)[
            :, :, : 2 * nv
        ]
        largest = float(np.abs(gains).max()) if gains.size else 0.0
        if not largest <= MAX_GAIN:
            raise FeedbackError(
                f"gains of {largest:.3g} exceed {MAX_GAIN:g}: a degenerate linearisation"
            )
        # [time, qpos, qvel, ...] of STATE_SPEC -> [qpos, qvel]
        return gains, path[:, 1 : 1 + nq + nv].copy()

    def add_to(
        self,
        plan: Spline,
        weights: np.ndarray,
        initial_state: np.ndarray,
        mocap: np.ndarray,
        num_rollouts: int,
        period: float | None = None,
    ) -> FeedbackPlan:
        """`plan` with the TVLQR gains around its controls at the T steps (`weights` (T, num_nodes)
        @ its knots, clamped) rolled out from `initial_state` (STATE_SPEC) under the (7 nmocap,)
        `mocap` poses, weighed by `task.feedback_cost()`, linearised at as many steps as an update
        of `num_rollouts` rollouts pays for (`num_points`), with exact per-step gains over its first
        SERVED_PERIODS control `period`s (s; all of it by default) and held ones beyond
        (`tvlqr_gains`); without gains, and saying why in `feedback_error`, when they failed."""
        task = self.task
        assert task is not None, "FeedbackGains.add_to needs the task"
        gains = nominal_states = error = None
        controls = np.minimum(np.maximum(weights @ plan.knots, plan.low), plan.high)
        try:
            if task.low_level() is not None:
                raise FeedbackError(
                    f"{type(task).__name__} plans a low-level policy's commands, and "
                    "feedback gains are only for "
                    "plans of the actuators"
                )
            state_weights, control_weights = (
                np.asarray(w, dtype=float) for w in task.feedback_cost()
            )
            finite_weights(state_weights, control_weights, self.model, task.nu)
            points = self.num_points(len(controls), num_rollouts)
            exact = (
                None
                if period is None
                else math.ceil(SERVED_PERIODS * period / self.model.opt.timestep)
            )
            gains, nominal_states = self.compute(
                initial_state, mocap, controls, state_weights, control_weights, points, exact
            )
        except FeedbackError as err:
            error = str(err)
        return FeedbackPlan(plan, self.model, gains, nominal_states, error)

    def close(self) -> None:
        """Stop the worker threads."""
        self._executor.shutdown(wait=True, timeout=0.5)


def finite_weights(
    state_weights: np.ndarray, control_weights: np.ndarray, model: mujoco.MjModel, nu: int
) -> None:
    """Raise FeedbackError unless the weights have the shapes (2 nv,) and (nu,), are finite, Q >= 0
    and R > 0."""
    if np.shape(state_weights) != (2 * model.nv,) or np.shape(control_weights) != (nu,):
        raise FeedbackError(
            f"feedback_cost must return (2 nv,) = ({2 * model.nv},) state weights and (nu,) "
            f"= ({nu},) control "
            f"weights, got shapes {np.shape(state_weights)} and {np.shape(control_weights)}"
        )
    if not (np.all(np.isfinite(state_weights)) and np.all(state_weights >= 0)):
        raise FeedbackError("feedback_cost's state weights must be finite and at least 0")
    if not (
        np.all(np.isfinite(control_weights)) and np.all(control_weights > 0)
    ) or not math.isfinite(float(np.sum(control_weights))):
        raise FeedbackError("feedback_cost's control weights must be finite and above 0")
