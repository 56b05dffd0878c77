"""mujoco.sysid's hooks for judo's fit (judo.sysid.fit): the windows as its ModelSequences, the
residual that compares them (states or measured sensors), and the rollouts behind it: every window
of a candidate in one call, the logged actions delayed (--fit-delay), and, comparing sensors, each
window's start refined to its own measurements under the candidate (`refine_starts`).
"""

import contextlib
import io
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.model_overrides import overridden
from judo.sysid.windows import Windows, delayed_controls, prediction_residuals, spread


def least_squares(
    sysid: Any,
    model: mujoco.MjModel,
    windows: Windows,
    names: list[str],
    bounds: list[tuple[float, float, float]],
    scale: np.ndarray,
    build_model: Callable[[Any], mujoco.MjModel],
    delay_name: str | None,
    max_iters: int,
    counted: Callable[[], None],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """mujoco.sysid's least-squares fit to `windows` of the parameters `names`, each (low, high,
    start) in `bounds` and of size `scale` (P,), a candidate's model built by `build_model`, the
    actions delayed by the parameter `delay_name` where given; `counted()` after each evaluation of
    the residual. Returns ((P,) fitted, (P,) 95% half-widths, (rows, P) the residual's Jacobian at
    the fit)."""
    params = sysid.ParameterDict()
    for name, (low, high, start) in zip(names, bounds, strict=True):
        params.add(sysid.Parameter(name, nominal=start, min_value=low, max_value=high))
    sequences = model_sequences(sysid, model, windows)
    # each candidate's windows start where its own motion best explains them
    if windows.columns is not None:
        rollout = refined_rollout(sysid, model, windows, delay_name)
    else:
        rollout = (
            delayed_rollout(sysid, model, windows, delay_name) if delay_name is not None else None
        )
    compare = observed_residual(sysid, spread(windows), windows.columns)
    residual = batched_residual(sysid, sequences.measured_rollout, build_model, compare, rollout)

    def evaluated(x: np.ndarray, candidate: Any, **kwargs: Any) -> Any:
        counted()
        return residual(x, candidate, **kwargs)

    with contextlib.redirect_stdout(io.StringIO()):
        opt_params, result = sysid.optimize(
            params, evaluated, optimizer="mujoco", verbose=False, max_iters=max_iters, x_scale=scale,  # noqa: E501
            output=io.StringIO(),
        )  # fmt: skip
        fitted = np.array([opt_params[name].value[0] for name in names])
        residuals, _, _ = residual(fitted, opt_params)
        jacobian = np.asarray(result.jac, dtype=float)
        _, interval = sysid.calculate_intervals(residuals, jacobian)
    return fitted, np.asarray(interval, dtype=float), jacobian


def refine_starts(
    model: mujoco.MjModel, windows: Windows, delay: float = 0.0, iterations: int = 3
) -> Windows:
    """`windows` (comparing sensors) with each start state moved to the one from which `model`,
    under the logged actions `delay` s late, best predicts the window's own measured sensors: a few
    damped Gauss-Newton steps on the (2 nv,) start (qpos moved on its manifold, mj_integratePos),
    one window at a time but every window's rollouts in one `mujoco.rollout` call (the Jacobian by
    forward differences). The logged estimate a window starts from was made by the planning model,
    whose errors it carries; refined, it is the state the measurements themselves say, and the fit
    compares the model's motion rather than the estimator's lag."""
    from dataclasses import replace

    from mujoco import rollout

    assert windows.columns is not None
    count, nv, nq = len(windows.starts), model.nv, model.nq
    tangent = 2 * nv
    controls = delayed_controls(windows, delay, float(model.opt.timestep))
    # (W * (2 nv + 1), K, nu): the start, then each nudge
    controls = np.repeat(controls, tangent + 1, axis=0)
    scale = spread(windows)
    mask = np.isfinite(windows.measured)
    measured = np.where(mask, windows.measured, 0.0)
    eps = 1e-6
    # a state row is [time, qpos, qvel, ...]
    qpos_at = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)
    qvel_at = qpos_at + nq
    starts = windows.starts.copy()
    data = mujoco.MjData(model)
    for _ in range(iterations):
        base = full_states(model, starts, data)
        initial = np.repeat(base[:, None], tangent + 1, axis=1)  # (W, 2 nv + 1, state size)
        for dof in range(nv):
            initial[:, 1 + nv + dof, qvel_at + dof] += eps
            if nq == nv:  # no ball or free joint: qpos moves as the tangent does
                initial[:, 1 + dof, qpos_at + dof] += eps
            else:
                for w in range(count):
                    qpos, step = starts[w, :nq].copy(), np.zeros(nv)
                    step[dof] = eps
                    mujoco.mj_integratePos(model, qpos, step, 1.0)
                    initial[w, 1 + dof, qpos_at : qpos_at + nq] = qpos
        _, sensordata = rollout.rollout(
            model, data, initial.reshape(count * (tangent + 1), -1), controls
        )
        predicted = sensordata[..., windows.columns].reshape(
            count, tangent + 1, *windows.measured.shape[1:]
        )
        # (W, K * m)
        residual = np.where(mask, (measured - predicted[:, 0]) / scale, 0.0).reshape(count, -1)
        nudged = (predicted[:, 1:] - predicted[:, :1]) / eps / scale  # (W, 2 nv, K, m)
        jacobian = (
            np.where(mask[:, None], nudged, 0.0).reshape(count, tangent, -1).transpose(0, 2, 1)
        )
        normal = np.einsum("wri,wrj->wij", jacobian, jacobian)
        damping = 1e-3 * np.einsum("wii->wi", normal)[:, :, None] * np.eye(tangent) + 1e-9 * np.eye(
            tangent
        )
        moves = np.linalg.solve(
            normal + damping, np.einsum("wri,wr->wi", jacobian, residual)[..., None]
        )[..., 0]
        starts[:, nq:] += moves[:, nv:]
        if nq == nv:
            starts[:, :nq] += moves[:, :nv]
        else:
            for w in range(count):
                qpos = starts[w, :nq].copy()
                mujoco.mj_integratePos(model, qpos, moves[w, :nv], 1.0)
                starts[w, :nq] = qpos
    return replace(windows, starts=starts)


def full_states(
    model: mujoco.MjModel, starts: np.ndarray, data: mujoco.MjData | None = None
) -> np.ndarray:
    """(W, state size) mjSTATE_FULLPHYSICS rows, for `mujoco.rollout`, of the (W, nq + nv) [qpos,
    qvel] `starts` (the rest of the state as MjData's defaults)."""
    scratch = mujoco.MjData(model) if data is None else data
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    mujoco.mj_resetData(model, scratch)
    rows = np.zeros((len(starts), mujoco.mj_stateSize(model, spec)))
    for row, start in zip(rows, starts, strict=True):
        scratch.qpos[:], scratch.qvel[:] = start[: model.nq], start[model.nq :]
        mujoco.mj_getState(model, scratch, row, spec)
    return rows


def refined_residuals(model: mujoco.MjModel, windows: Windows, delay: float) -> np.ndarray:
    """(W, K, D) `prediction_residuals` of `model`; comparing sensors, from the starts refined under
    `model` itself."""
    if windows.columns is not None:
        windows = refine_starts(model, windows, delay)
    return prediction_residuals(model, windows, delay)


def refined_rollout(
    sysid: Any, model: mujoco.MjModel, windows: Windows, delay_name: str | None
) -> Callable[..., Any]:
    """mujoco.sysid's custom_rollout hook when comparing sensors: each candidate model (one per
    finite-difference column) rolls every window out from its start refined under that candidate
    (`refine_starts`: the start state from which the candidate best predicts the window's own
    measurements, found from the logged estimate), under the logged actions, delayed by the
    candidate's parameter `delay_name` (s) where one is given. So the residual of a candidate is its
    best over the windows' start states (variable projection), and the fit weighs the model's motion
    rather than the planning model's errors that the logged estimate carries."""
    count = len(windows.starts)
    timestep = float(model.opt.timestep)
    times = np.arange(windows.controls.shape[1] + 1) * timestep

    def rollout(
        *,
        models: Any,
        datas: Any,
        control_signal: Any,
        initial_states: Any,
        param_dicts: Any,
        **kwargs: Any,
    ):
        del control_signal, initial_states
        signals, starts = [], []
        for column, candidate in enumerate(param_dicts):
            delay = float(candidate[delay_name].value[0]) if delay_name is not None else 0.0
            refined = refine_starts(models[column * count], windows, delay)
            starts.append(full_states(model, refined.starts))
            for controls in delayed_controls(windows, delay, timestep):
                signals.append(
                    sysid.TimeSeries.from_control_names(
                        times, np.vstack([controls, controls[-1:]]), model
                    )
                )
        return sysid.sysid_rollout(models, datas, signals, np.concatenate(starts), **kwargs)

    return rollout


def batched_residual(
    sysid: Any,
    trajectories: list[Any],
    build_model: Callable[[Any], mujoco.MjModel],
    modify_residual: Callable[..., Any],
    custom_rollout: Callable[..., Any] | None,
) -> Callable[..., Any]:
    """mujoco.sysid's residual over all windows at once: `sysid.model_residual` on the list of the
    windows' trajectories builds each candidate model once and rolls every window out in one
    threaded `mujoco.rollout` call (`sysid.residual` calls it once per window, building the model
    and its threads each time). Returns fn(x, params) -> ([residual (W * K * (nq + nv),) or (W * K *
    (nq + nv), n) for a batch x of n columns], predicted, measured) in `sysid.residual`'s row order,
    window after window."""
    count = len(trajectories)

    def residual(x: np.ndarray, params: Any, **kwargs: Any) -> Any:
        values, predicted, measured = sysid.model_residual(
            x,
            params,
            build_model,
            trajectories,
            modify_residual,
            custom_rollout,
            return_pred_all=kwargs.get("return_pred_all", False),
            resample_true=False,  # the logged actions are one per model step already
        )
        # (rows of one window, columns * windows) -> (windows * rows of one, columns)
        if np.ndim(x) > 1:
            columns = np.shape(x)[1]
            values = values.reshape(-1, columns, count).transpose(2, 0, 1).reshape(-1, columns)
        return [values], predicted, measured

    return residual


def delayed_rollout(
    sysid: Any, model: mujoco.MjModel, windows: Windows, name: str
) -> Callable[..., Any]:
    """mujoco.sysid's custom_rollout hook for --fit-delay: rolls each window out under its logged
    actions delayed by the candidate's parameter `name` (s), `delayed_controls` of the action
    history before it, the control signal delayed as mujoco.sysid's signal delay reads a sensor (at
    t - delay, linearly interpolated)."""
    count = len(windows.starts)
    times = np.arange(windows.controls.shape[1] + 1) * float(model.opt.timestep)

    def rollout(
        *,
        models: Any,
        datas: Any,
        control_signal: Any,
        initial_states: Any,
        param_dicts: Any,
        **kwargs: Any,
    ):
        del control_signal
        signals = []
        for candidate in param_dicts:  # one per finite-difference column, each over every window
            delayed = delayed_controls(
                windows, float(candidate[name].value[0]), float(model.opt.timestep)
            )
            for controls in delayed:
                signals.append(
                    sysid.TimeSeries.from_control_names(
                        times, np.vstack([controls, controls[-1:]]), model
                    )
                )
        assert len(signals) == len(param_dicts) * count
        return sysid.sysid_rollout(models, datas, signals, initial_states, **kwargs)

    return rollout


def model_sequences(sysid: Any, model: mujoco.MjModel, windows: Windows) -> Any:
    """mujoco.sysid's ModelSequences of the windows: each a sequence with its start state, its
    actions (K, nu) at times 0, dt, ... and what it is compared with, (K + 1, D) at times 0, dt,
    ..., as one custom observation ("observed"; `observed_residual` compares it: joint-named signals
    need every joint named, and the LEAP hand's are not). Comparing states, the rows are the start
    and the logged state after each step; comparing sensors, the measured sensors taken after 0, 1,
    ..., K - 1 steps, then a row of NaN."""
    times = np.arange(windows.controls.shape[1] + 1) * float(model.opt.timestep)
    width = windows.measured.shape[-1]
    mapping = {"observed": (sysid.SignalType.CustomObs, np.arange(width))}
    data = mujoco.MjData(model)
    starts, controls, measured = [], [], []
    for start, control, observed in zip(
        windows.starts, windows.controls, windows.measured, strict=True
    ):
        data.qpos[:], data.qvel[:] = start[: model.nq], start[model.nq :]
        starts.append(
            sysid.create_initial_state(model, data.qpos.copy(), data.qvel.copy(), data.act.copy())
        )
        # mujoco.sysid's layout: N states from the start and N controls, the last of which it never
        # applies
        controls.append(
            sysid.TimeSeries.from_control_names(times, np.vstack([control, control[-1:]]), model)
        )
        rows = (
            np.vstack([start, observed])
            if windows.columns is None
            else np.vstack([observed, np.full(width, np.nan)])
        )
        measured.append(sysid.TimeSeries(times, rows, mapping))
    sequence_names = [f"window_{i}" for i in range(len(starts))]
    return sysid.ModelSequences(
        "judo",
        PlanningModel(model),
        sequence_names,
        starts,
        controls,
        measured,
        allow_missing_sensors=True,
    )


def observed_residual(
    sysid: Any, spread: np.ndarray, columns: np.ndarray | None
) -> Callable[..., Any]:
    """mujoco.sysid's modify_residual hook: what the rollout predicts against what the window
    compares, each coordinate divided by its spread (D,) in the whole log, 0 where nothing was
    measured; returns (residual (K, D), predicted, measured) as TimeSeries of the same layout.

    `columns` None compares states: the rolled-out [qpos, qvel] after each step against the logged
    one. Else the rollout's sensordata columns `columns` (the task's measured sensors; its row j is
    the sensors of the state after j steps) against the measured sensors taken after 0, ..., K - 1
    steps."""

    def residual(
        params: Any, predicted: Any, measured: Any, model: mujoco.MjModel, *args: Any, **kwargs: Any
    ) -> Any:
        del params, args
        if columns is None:
            width = model.nq + model.nv
            # a row [time, qpos, qvel, ...] after each step
            values = np.asarray(kwargs["state"])[:, 1 : 1 + width]
            # start given
            target = sysid.TimeSeries(
                measured.times[1:], measured.data[1:], measured.signal_mapping
            )
        else:
            steps = len(measured.times) - 1
            values = np.asarray(predicted.data)[:steps, columns]
            target = sysid.TimeSeries(
                measured.times[:steps], measured.data[:steps], measured.signal_mapping
            )
        prediction = sysid.TimeSeries(target.times, values, target.signal_mapping)
        difference = (target.data - values) / spread
        return np.where(np.isnan(difference), 0.0, difference), prediction, target

    return residual


class PlanningModel:
    """Stands for the MjSpec that mujoco.sysid.ModelSequences compiles once for the measured
    trajectories' layout: the planning model itself (a task holds a compiled model, not its spec;
    `fit`'s build_model never reads it)."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model

    def compile(self) -> mujoco.MjModel:
        """A copy of the planning model."""
        return overridden(self.model, {})
