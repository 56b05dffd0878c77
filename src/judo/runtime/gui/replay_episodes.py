"""The episodes `python -m judo replay` plays: the demos of a collect file (or a GUI recording), or
the one episode of a ROS 2 bridge's MCAP log, read and checked against the task's plant model, and
the plan traces drawn with them.
"""

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from judo.recording.dataset import DatasetError, demo_name, import_h5py


@dataclass
class Demo:
    """One recorded episode: qpos (S, nq), mocap_pos (S, nmocap, 3) or None, times (S,), metrics,
    success (None: not judged, a bridge log); plan_times (U,) the reading times of its plans, and
    has_traces: whether the file holds their traces."""

    seed: int
    qpos: np.ndarray
    mocap_pos: np.ndarray | None
    times: np.ndarray
    metrics: dict[str, float]
    success: bool | None
    plan_times: np.ndarray
    has_traces: bool


def read_demos(path: Path) -> tuple[dict[str, Any], dict[int, Demo]]:
    """(env_args, {seed: Demo}) of a collect file, in seed order; DatasetError when it is not one,
    naming the group, dataset, attribute or env_args entry that is missing or unreadable.
    `check_demos` checks the arrays against the task's model."""
    h5py = import_h5py("python -m judo replay")
    not_ours = f"{path} is not a file of `python -m judo collect`"
    try:
        with h5py.File(path, "r") as file:
            data = member(file, "data", "the file", "group")
            env_args = json.loads(member(data.attrs, "env_args", "data", "attribute"))
            dt = float(member(env_args, "plant_timestep", "data's env_args", "entry"))
            for key in ("task", "optimizer"):  # the page's title
                member(env_args, key, "data's env_args", "entry")
            if not 0 < dt <= 1.0:  # NaN too
                raise DatasetError(
                    "data's env_args entry 'plant_timestep' must be above 0 and at most 1 s, "
                    f"got {dt}"
                )
            demos = {}
            for name in sorted(file["data"], key=demo_seed):
                group, where = file["data"][name], f"data/{name}"
                qpos = member(group, "obs/qpos", where, "dataset")[:]
                mocap = group["obs/mocap_pos"][:] if "obs/mocap_pos" in group else None
                seed = int(member(group.attrs, "seed", where, "attribute"))
                times = dt * np.arange(1, len(qpos) + 1)
                metrics = json.loads(member(group.attrs, "metrics", where, "attribute"))
                plan_times, has_traces = (
                    member(group, "plan/times", where, "dataset")[:],
                    "plan/traces" in group,
                )
                traces = group["plan/traces"].shape if has_traces else (len(plan_times), 0, 0, 0, 3)
                if len(traces) != 5 or traces[0] != len(plan_times) or traces[-1] != 3:
                    raise DatasetError(
                        f"{where}/plan/traces must have shape ({len(plan_times)}, ..., 3), got "
                        f"{traces}"
                    )
                success = bool(member(group.attrs, "success", where, "attribute"))
                demos[seed] = Demo(
                    seed, qpos, mocap, times, metrics, success, plan_times, has_traces
                )
    except DatasetError as err:
        raise DatasetError(f"{not_ours}: {err}") from None
    # not HDF5, unreadable JSON, a name that is not demo_<seed>
    except (OSError, ValueError, TypeError) as err:
        raise DatasetError(f"{not_ours}: {' '.join(str(err).split())[:200]}") from None
    if not demos:
        raise DatasetError(f"{path} holds no episodes")
    return env_args, demos


def read_episodes(path: Path, task: str | None = None) -> tuple[dict[str, Any], dict[int, Demo]]:
    """(env_args, {seed: Demo}) of a collect file (`read_demos`), or of a ROS 2 bridge's MCAP log:
    one demo of seed 0, its times the JointState stamps from one plant step on. `task` names an MCAP
    log's task where the log does not (a collect file names its own: DatasetError for another)."""
    if path.suffix.lower() != ".mcap":
        env_args, demos = read_demos(path)
        if task is not None and task != env_args["task"]:
            raise DatasetError(
                f"{path}: a file of task {env_args['task']!r}, not of --task {task!r}"
            )
        return env_args, demos
    from judo.ros2.mcap_read import read_bridge_log

    log = read_bridge_log(path, task, "python -m judo replay LOG.mcap")
    times = log.times - log.times[0] + log.timestep
    env_args = {"task": log.task, "optimizer": "ROS 2 bridge log", "plant_timestep": log.timestep}
    return env_args, {0: Demo(0, log.qpos, log.mocap_pos, times, {}, None, np.zeros(0), False)}


def member(container: Any, key: str, where: str, kind: str) -> Any:
    """`container[key]` (an h5py group or attributes, or a dict), or DatasetError "WHERE has no KIND
    'KEY'"."""
    try:
        return container[key]
    except KeyError:
        raise DatasetError(f"{where} has no {kind} {key!r}") from None


def demo_seed(name: str) -> int:
    """The seed of group `name` ("demo_<seed>"); ValueError naming the group otherwise."""
    seed = name.removeprefix("demo_")
    if name == seed or not seed.isdigit():
        raise ValueError(f"data holds {name!r}, which is not a demo_<seed> group")
    return int(seed)


def check_demos(path: Path, demos: dict[int, Demo], model: Any, task: str) -> None:
    """DatasetError unless every demo's arrays fit `model` (the task's plant model) and are finite:
    qpos (S, nq) with S >= 1, obs/mocap_pos (S, 3 nmocap) where present, plan/times (U,). Reshapes
    mocap_pos to (S, nmocap, 3)."""
    for seed, demo in demos.items():
        where = f"{path}: data/{demo_name(seed)}"
        rows = len(demo.qpos)
        arrays: dict[str, tuple[np.ndarray, tuple[int, ...], str]] = {
            "obs/qpos": (
                demo.qpos,
                (rows, model.nq),
                f"(S, {model.nq}) for {task}'s nq = {model.nq}",
            )
        }
        if demo.mocap_pos is not None:
            width = 3 * model.nmocap
            arrays["obs/mocap_pos"] = (
                demo.mocap_pos,
                (rows, width),
                f"(S, {width}) for {task}'s {model.nmocap} mocap bodies",
            )
        arrays["plan/times"] = (demo.plan_times, (len(demo.plan_times),), "(U,)")
        for key, (values, shape, expected) in arrays.items():
            if values.ndim != len(shape) or values.shape != shape or not rows:
                raise DatasetError(f"{where}/{key} must have shape {expected}, got {values.shape}")
            if not np.issubdtype(values.dtype, np.number):
                raise DatasetError(f"{where}/{key} must hold numbers, got {values.dtype}")
            bad = np.flatnonzero(~np.isfinite(values).all(axis=tuple(range(1, values.ndim))))
            if bad.size:
                raise DatasetError(
                    f"{where}/{key} holds non-finite values (NaN or inf) in {bad.size} of "
                    f"its {len(values)} rows, "
                    f"the first row {bad[0]}"
                )
        if demo.mocap_pos is not None:
            demo.mocap_pos = demo.mocap_pos.reshape(rows, model.nmocap, 3)


def read_traces(path: Path, seed: int) -> np.ndarray:
    """(U, 1 + num_shown, T, num_trace_sensors, 3) the plan traces of demo `seed` (read when it is
    shown)."""
    h5py = import_h5py("python -m judo replay")
    with h5py.File(path, "r") as file:
        return file["data"][demo_name(seed)]["plan/traces"][:]


def unpadded(traces: np.ndarray) -> np.ndarray:
    """(num_traces, T, num_trace_sensors, 3) one plan's traces without the NaN padding of a file
    whose plans differ in shape (a recording across an edit of the horizon or of max_num_traces)."""
    finite = np.isfinite(traces)
    steps = finite.any(axis=(0, 2, 3))
    traces, finite = traces[:, steps], finite[:, steps]
    return traces[finite.all(axis=(1, 2, 3))]
