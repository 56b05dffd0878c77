"""`SystemState`, one reading of the plant: the type a `System` returns and an `Estimator` consumes;
and how a reading enters planning: checked (`checked_reading`) and put into an MjData (`model_at`,
with its mocap poses: `set_mocap_poses`, `mocap_vector`, `mocap_metadata`).

It lives in core so that the estimator contract (core/estimator.py) and the estimators do not import
the runtime; `judo.loop.system` uses it beside the `System` interface, and `judo` exports it to
users.
"""

import math
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError
from judo.core.model import STATE_SPEC

TIME_TOLERANCE = 1e-9
"""Seconds within which two times count as the same: a reading's stamp, a sample or an update due, a
plan's time and a row's (all sums of timesteps, so equal times may differ in their last bits)."""


@dataclass
class SystemState:
    """One reading of the plant.

    Attributes:
        state: (nq + nv,) [qpos, qvel], or None from a System that measures only sensors.
        time: plant time in seconds at which the measurement was *taken* (so a late reading is known
            as late); with per-sensor times (metadata "sensor_times"), the newest of them.
        metadata: extra values for the controller and reward, e.g. "mocap_pos" (nmocap, 3), and
            "sensor_times" (len(Task.measured_sensors),): when each sensor's value was taken, if
            they differ.
        sensors: (measured size,) values of the task's `measured_sensors`, in
            order (see `Task.measured`), or None when the System measures none.
    """

    state: np.ndarray | None
    time: float
    metadata: dict[str, Any] = field(default_factory=dict)
    sensors: np.ndarray | None = None


def checked_reading(state: Any, time: float, num_state: int, doing: str) -> np.ndarray:
    """`state` as a (num_state,) float array, checked before an update uses it.

    Raises ConfigError for another shape, and JudoError "cannot {doing} a non-finite reading (...);
    keeping the previous plan" for a non-finite state entry or time (no reading time in the message:
    the same fault reads the same, so the log's repeat filter holds).
    """
    state = np.asarray(state, dtype=float)
    if state.shape != (num_state,):
        raise ConfigError(f"state must have shape ({num_state},) = (nq + nv,), got {state.shape}")
    if not (np.isfinite(state).all() and math.isfinite(time)):
        bad = np.flatnonzero(~np.isfinite(state)).tolist()
        what = f"non-finite state entries {bad}" if bad else f"non-finite time {time}"
        raise JudoError(f"cannot {doing} a non-finite reading ({what}); keeping the previous plan")
    return state


def set_mocap_poses(model: mujoco.MjModel, data: mujoco.MjData, metadata: dict | None) -> None:
    """Copy a reading's "mocap_pos" (nmocap, 3) and "mocap_quat" (nmocap, 4), where `metadata` has
    them, into `data`: mocap bodies (goals, targets) are not part of [qpos, qvel], so a System
    publishes them beside it."""
    if not metadata or not model.nmocap:
        return
    for key in ("mocap_pos", "mocap_quat"):
        if key in metadata:
            getattr(data, key)[:] = metadata[key]


def model_at(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    state: np.ndarray,
    time: float | None = None,
    metadata: dict | None = None,
    *,
    forward: bool = True,
) -> mujoco.MjData:
    """Put `state` into `data`, a scratch MjData of `model`, with the mocap poses in `metadata`
    where it has them (see `set_mocap_poses`), then run `mj_forward` (unless `forward` is False);
    returns `data`.

    `state` is a reading's (nq + nv,) [qpos, qvel] at sim `time` (None: `data.time` is kept), or a
    full-physics (nstate,) state of STATE_SPEC, which carries its own time, act and plugin state
    (`time` is not used). The rest of `data` (ctrl, warm start, and act under a [qpos, qvel] state)
    is left as it was."""
    if len(state) == model.nq + model.nv:
        if time is not None:
            data.time = time
        data.qpos[:] = state[: model.nq]
        data.qvel[:] = state[model.nq :]
    else:
        mujoco.mj_setState(model, data, state, STATE_SPEC)
    set_mocap_poses(model, data, metadata)
    if forward:
        mujoco.mj_forward(model, data)
    return data


def mocap_vector(data: mujoco.MjData) -> np.ndarray:
    """(7 nmocap,) `data`'s mocap poses as a rollout's inputs take them: [mocap_pos.ravel(),
    mocap_quat.ravel()]."""
    return np.concatenate([data.mocap_pos.ravel(), data.mocap_quat.ravel()])


def mocap_metadata(model: mujoco.MjModel, mocap: np.ndarray) -> dict[str, np.ndarray]:
    """The "mocap_pos" (nmocap, 3) and "mocap_quat" (nmocap, 4) of a (7 nmocap,) `mocap_vector`, as
    metadata."""
    split = 3 * model.nmocap
    return {"mocap_pos": mocap[:split].reshape(-1, 3), "mocap_quat": mocap[split:].reshape(-1, 4)}
