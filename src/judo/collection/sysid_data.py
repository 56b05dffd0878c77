"""The data a sysid fit reads: logged episodes (judo's HDF5 logs and the ROS 2 bridge's MCAP) and the K-step
windows cut from them, with the actions before each (for a fitted delay) and the prediction error over them.

h5py (the `collect` extra) and the MCAP reader (the `ros2` extra) are imported only when a log of theirs is read.
"""

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.collection.dataset import DatasetError, import_h5py
from judo.core.errors import ConfigError


@dataclass
class Episode:
    """One logged episode: qpos (S, nq), qvel (S, nv) after each step and actions (S, nu) served during it."""

    name: str
    qpos: np.ndarray
    qvel: np.ndarray
    actions: np.ndarray


def read_logs(paths: list[Path], task_name: str, model: mujoco.MjModel) -> list[Episode]:
    """Every episode of the logs at `paths`: HDF5 (collect's, the GUI's) or the bridge's MCAP (`read_mcap_log`).
    Raises DatasetError, in one line naming the file, for a file that is missing, empty, not HDF5 or corrupt, holds
    another task's episodes, has no episodes, or an episode without actions or of other sizes than `model`."""
    episodes = []
    for path in paths:
        if path.suffix.lower() == ".mcap":
            episodes.extend(read_mcap_log(path, task_name, model))
            continue
        if not path.is_file():
            raise DatasetError(f"{path}: no such log file; give collect's .h5 files or GUI recordings")
        if path.stat().st_size == 0:
            raise DatasetError(f"{path}: the file is empty; give a log that collect or the GUI's recorder wrote")
        try:
            with import_h5py("python -m judo sysid").File(path, "r") as file:
                episodes.extend(_read_file(file, path, task_name, model))
        except OSError as err:
            raise DatasetError(f"{path}: not a readable HDF5 log ({str(err).splitlines()[0][:120]})") from None
    return episodes


def _read_file(file: Any, path: Path, task_name: str, model: mujoco.MjModel) -> list[Episode]:
    data = file.get("data")
    if data is None or "env_args" not in data.attrs:
        raise DatasetError(f"{path}: not a judo log (no data group with env_args); give collect's or the GUI's files")
    try:
        env_args = json.loads(data.attrs["env_args"])
    except (TypeError, ValueError):
        raise DatasetError(f"{path}: its env_args are not JSON; the file is corrupt") from None
    logged_task = env_args.get("task")
    if logged_task != task_name:
        raise DatasetError(f"{path}: a log of task {logged_task!r}, not of --task {task_name!r}")
    step = env_args.get("plant_timestep")
    if step is not None and not np.isclose(float(step), model.opt.timestep):
        raise DatasetError(f"{path}: logged at a plant timestep of {step} s, the model steps {model.opt.timestep} s")
    episodes = []
    for name in sorted(data):
        demo = data[name]
        if "actions" not in demo:
            raise DatasetError(f"{path}: episode {name} has no actions; sysid needs the actions served to the plant")
        if "obs" not in demo or "qpos" not in demo["obs"] or "qvel" not in demo["obs"]:
            raise DatasetError(f"{path}: episode {name} has no obs/qpos and obs/qvel")
        qpos, qvel, actions = (
            np.asarray(x, dtype=float) for x in (demo["obs/qpos"], demo["obs/qvel"], demo["actions"])
        )
        sizes = (qpos.shape[1:], qvel.shape[1:], actions.shape[1:])
        if sizes != ((model.nq,), (model.nv,), (model.nu,)) or not len(qpos) == len(qvel) == len(actions):
            raise DatasetError(
                f"{path}: episode {name} has qpos, qvel, actions of widths {sizes}; the model needs "
                f"({model.nq},), ({model.nv},), ({model.nu},) on every step"
            )
        episodes.append(Episode(f"{path.name}:{name}", qpos, qvel, actions))
    if not episodes:
        raise DatasetError(f"{path}: the log holds no episodes")
    return episodes


def read_mcap_log(path: Path, task_name: str, model: mujoco.MjModel) -> list[Episode]:
    """The episodes of the ROS 2 bridge's MCAP log at `path`: its runs of rows one step of `model` apart with a
    command in force (`judo.ros2.mcap_read.BridgeLog.step_runs`, whose errors name the file)."""
    from judo.ros2.mcap_read import read_bridge_log

    log = read_bridge_log(path, task_name, "python -m judo sysid LOG.mcap")
    runs = log.step_runs(float(model.opt.timestep))
    return [Episode(f"{path.name}:rows {r.start}-{r.stop - 1}", log.qpos[r], log.qvel[r], log.actions[r]) for r in runs]


@dataclass
class Windows:
    """K-step windows cut from the episodes: each rolled out from its start state under its logged actions.

    Attributes:
        starts: (W, nq + nv) logged state before each window's first step.
        controls: (W, K, nu) actions served during the window's steps.
        measured: (W, K, nq + nv) logged state after each of the window's steps.
        history: (W, H, nu) actions served during the H steps before the window (H = 0 unless a delay is fitted).
    """

    starts: np.ndarray
    controls: np.ndarray
    measured: np.ndarray
    history: np.ndarray


def cut_windows(episodes: list[Episode], steps: int, history: int = 0) -> Windows:
    """Non-overlapping windows of `steps` steps from every episode, each with the `history` actions before it
    (an episode's first row is a window's start only, since the state before it is not logged); ConfigError
    where no episode is long enough for one."""
    starts, controls, measured, before = [], [], [], []
    for episode in episodes:
        states = np.concatenate([episode.qpos, episode.qvel], axis=1)
        for first in range(1 + history, len(states) - steps + 1, steps):
            starts.append(states[first - 1])
            controls.append(episode.actions[first : first + steps])
            measured.append(states[first : first + steps])
            before.append(episode.actions[first - history : first])
    if not starts:
        longest = max((len(e.qpos) for e in episodes), default=0)
        raise ConfigError(
            f"--window of {steps} steps (after {history} steps of action history) is longer than every logged "
            f"episode (the longest has {longest})"
        )
    nu = episodes[0].actions.shape[1]
    return Windows(
        np.array(starts), np.array(controls), np.array(measured), np.array(before).reshape(len(starts), history, nu)
    )


def delayed_controls(windows: Windows, delay: float, timestep: float) -> np.ndarray:
    """(W, K, nu) the control in force during each window's steps when every logged action takes effect `delay`
    seconds late: the logged actions (piecewise constant, one per step) read at t - delay, interpolated linearly
    between steps (so the residual is continuous in the delay). `delay` is at most H steps of `windows.history`."""
    if delay <= 0.0:
        return windows.controls
    history = windows.history.shape[1]
    extended = np.concatenate([windows.history, windows.controls], axis=1)  # (W, H + K, nu)
    at = history + np.arange(windows.controls.shape[1]) - delay / timestep  # fractional row of each step's control
    low = np.clip(np.floor(at).astype(int), 0, extended.shape[1] - 1)
    high = np.clip(low + 1, 0, extended.shape[1] - 1)
    fraction = (at - np.floor(at))[None, :, None]
    return (1.0 - fraction) * extended[:, low] + fraction * extended[:, high]


def prediction_error(model: mujoco.MjModel, windows: Windows, delay: float = 0.0) -> float:
    """RMS over windows and steps of the difference between `model`'s K-step predictions (under the logged actions
    `delay` seconds late) and the logged states, each state coordinate divided by its spread in the log (so angles,
    positions and velocities weigh alike)."""
    from mujoco import rollout

    state_size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    initial = np.zeros((len(windows.starts), state_size))
    data = mujoco.MjData(model)
    for row, start in enumerate(windows.starts):
        data.qpos[:], data.qvel[:] = start[: model.nq], start[model.nq :]
        mujoco.mj_getState(model, data, initial[row], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    controls = delayed_controls(windows, delay, float(model.opt.timestep))
    states, _ = rollout.rollout(model, data, initial, controls)
    qpos_at = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)  # rows are [time, qpos, qvel, ...]
    predicted = states[..., qpos_at : qpos_at + model.nq + model.nv]
    error = (predicted - windows.measured) / spread(windows)
    return float(np.sqrt(np.mean(np.square(error))))


def spread(windows: Windows) -> np.ndarray:
    """(nq + nv,) each state coordinate's standard deviation over the logged windows (1 where it never moves)."""
    spread = windows.measured.reshape(-1, windows.measured.shape[-1]).std(axis=0)
    return np.where(spread > 1e-9, spread, 1.0)
