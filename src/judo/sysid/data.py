"""The logs a sysid fit reads: logged episodes (judo's HDF5 logs and the ROS 2 bridge's MCAP), what
a fit of them compares, and which commands their steps were paired with. The windows cut from
them: judo.sysid.windows.

h5py (the `collect` extra) and the MCAP reader (the `ros2` extra) are imported only when a log of
theirs is read.
"""

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError
from judo.recording.dataset import DatasetError, import_h5py


@dataclass
class Episode:
    """One logged episode: qpos (S, nq), qvel (S, nv) after each step (NaN rows where the plant
    reported no state) and actions (S, nu) served during it; where the plant was observed through
    its sensors, also what it measured.

    Attributes:
        measured: (S, m) the task's measured sensors the plant reported after each step, or None.
        measured_age: (S, k) seconds between taking each of the k measured sensors' values and the
            end of the step it was read after, or None (each taken at the end of its step).
        estimate: (S, nq + nv) the estimator's state after each step (NaN before it started), or
            None.
        measured_sensors: (k,) the names of the measured sensors, in `measured`'s order.
        lead_actions: (L, nu) the actions served during the L steps before the first row (an MCAP
            log's commands in force then), or None where the log holds none (collect's HDF5: the
            episode starts there).
        commands: where the actions come from: "served" (collect's and the GUI's logs: the plant's
            own, in process), "applied" (a bridge log's commands the robot reported applying)
            or "sent" (a bridge log
            without them: the commands sent, which a command delay may shift).
    """

    name: str
    qpos: np.ndarray
    qvel: np.ndarray
    actions: np.ndarray
    measured: np.ndarray | None = None
    measured_age: np.ndarray | None = None
    estimate: np.ndarray | None = None
    measured_sensors: tuple[str, ...] = ()
    lead_actions: np.ndarray | None = None
    commands: str = "served"

    @property
    def states(self) -> np.ndarray:
        """(S, nq + nv) the logged plant state after each step."""
        return np.concatenate([self.qpos, self.qvel], axis=1)

    @property
    def has_states(self) -> bool:
        """Whether the plant reported its state (a simulator, or a robot's bridge) on any step."""
        return bool(np.isfinite(self.states).all(axis=1).any())


COMPARE_CHOICES = ("auto", "states", "sensors")
"""What a fit compares: auto (the measured sensors where every log holds them, else the states), the
logged plant states, or the measured sensors."""


def compared(episodes: list["Episode"], compare: str) -> str:
    """ "states" or "sensors": what the fit of `episodes` compares for `compare` (one of
    COMPARE_CHOICES). ConfigError, in one line naming the episode, where the logs hold no such
    data."""
    if compare == "auto":
        compare = "sensors" if all(e.measured is not None for e in episodes) else "states"
    for episode in episodes:
        if compare == "sensors" and episode.measured is None:
            raise ConfigError(
                f"{episode.name}: the log holds no measured sensors (obs/measured) to "
                "compare; its plant reported "
                "its state: fit with --compare states"
            )
        if compare == "states" and not episode.has_states:
            raise ConfigError(
                f"{episode.name}: the log holds no plant states (its plant reported only "
                "sensors): fit with "
                "--compare sensors"
            )
    return compare


def read_logs(paths: list[Path], task_name: str, model: mujoco.MjModel) -> list[Episode]:
    """Every episode of the logs at `paths`: HDF5 (collect's, the GUI's) or the bridge's MCAP
    (`read_mcap_log`). Raises DatasetError, in one line naming the file, for a file that is missing,
    empty, not HDF5 or corrupt, holds another task's episodes, has no episodes, or an episode
    without actions or of other sizes than `model`."""
    episodes = []
    for path in paths:
        if path.suffix.lower() == ".mcap":
            episodes.extend(read_mcap_log(path, task_name, model))
            continue
        if not path.is_file():
            raise DatasetError(
                f"{path}: no such log file; give collect's .h5 files or GUI recordings"
            )
        if path.stat().st_size == 0:
            raise DatasetError(
                f"{path}: the file is empty; give a log that collect or the GUI's recorder wrote"
            )
        try:
            with import_h5py("python -m judo sysid").File(path, "r") as file:
                episodes.extend(_read_file(file, path, task_name, model))
        except OSError as err:
            raise DatasetError(
                f"{path}: not a readable HDF5 log ({str(err).splitlines()[0][:120]})"
            ) from None
    return episodes


def _read_file(file: Any, path: Path, task_name: str, model: mujoco.MjModel) -> list[Episode]:
    data = file.get("data")
    if data is None or "env_args" not in data.attrs:
        raise DatasetError(
            f"{path}: not a judo log (no data group with env_args); give collect's or the GUI's "
            "files"
        )
    try:
        env_args = json.loads(data.attrs["env_args"])
    except (TypeError, ValueError):
        raise DatasetError(f"{path}: its env_args are not JSON; the file is corrupt") from None
    logged_task = env_args.get("task")
    if logged_task != task_name:
        raise DatasetError(f"{path}: a log of task {logged_task!r}, not of --task {task_name!r}")
    step = env_args.get("plant_timestep")
    if step is not None and not np.isclose(float(step), model.opt.timestep):
        raise DatasetError(
            f"{path}: logged at a plant timestep of {step} s, the model steps "
            f"{model.opt.timestep} s"
        )
    episodes = []
    for name in sorted(data):
        demo = data[name]
        if "actions" not in demo:
            raise DatasetError(
                f"{path}: episode {name} has no actions; sysid needs the actions served to the "
                "plant"
            )
        if "obs" not in demo or "qpos" not in demo["obs"] or "qvel" not in demo["obs"]:
            raise DatasetError(f"{path}: episode {name} has no obs/qpos and obs/qvel")
        qpos, qvel, actions = (
            np.asarray(x, dtype=float)
            for x in (demo["obs/qpos"], demo["obs/qvel"], demo["actions"])
        )
        sizes = (qpos.shape[1:], qvel.shape[1:], actions.shape[1:])
        if sizes != ((model.nq,), (model.nv,), (model.nu,)) or not len(qpos) == len(qvel) == len(
            actions
        ):
            raise DatasetError(
                f"{path}: episode {name} has qpos, qvel, actions of widths {sizes}; the "
                "model needs "
                f"({model.nq},), ({model.nv},), ({model.nu},) on every step"
            )
        episodes.append(
            Episode(
                f"{path.name}:{name}", qpos, qvel, actions, *_measurements(demo, path, name, model)
            )
        )
    if not episodes:
        raise DatasetError(f"{path}: the log holds no episodes")
    return episodes


def _measurements(demo: Any, path: Path, name: str, model: mujoco.MjModel) -> tuple[Any, ...]:
    """(measured (S, m), measured_age (S, k), estimate (S, nq + nv), measured sensor names) of an
    h5py demo group, each None (the names ()) where the log has none."""
    obs = demo["obs"]
    measured = np.asarray(obs["measured"], dtype=float) if "measured" in obs else None
    age = np.asarray(obs["measured_age"], dtype=float) if "measured_age" in obs else None
    estimate = None
    if "estimate_qpos" in obs and "estimate_qvel" in obs:
        estimate = np.concatenate(
            [np.asarray(obs["estimate_qpos"]), np.asarray(obs["estimate_qvel"])], axis=1
        )
        if estimate.shape[1] != model.nq + model.nv:
            raise DatasetError(
                f"{path}: episode {name}'s estimate has width {estimate.shape[1]}, not nq + nv"
            )
    names: tuple[str, ...] = ()
    if measured is not None:
        try:
            names = tuple(json.loads(demo.attrs.get("measured_sensors", "[]")))
        except (TypeError, ValueError):
            raise DatasetError(
                f"{path}: episode {name}'s measured_sensors are not JSON; the file is corrupt"
            ) from None
    return measured, age, estimate, names


LEAD_STEPS = 16
"""Steps of commands before each run of an MCAP log kept with its episode (`Episode.lead_actions`):
the history a fitted delay reads (up to sysid.MAX_DELAY) and the commands a command delay shifts
into the run's first windows."""


def read_mcap_log(path: Path, task_name: str, model: mujoco.MjModel) -> list[Episode]:
    """The episodes of the ROS 2 bridge's MCAP log at `path`, one per run of rows a whole number of
    steps of `model` apart with a command in force (`judo.ros2.bridge_log.BridgeLog.grid_runs`,
    whose errors name the file), laid on the model's step grid: a row every step, its state NaN
    where no joint state fell on it (a robot that publishes every k steps) and its action the
    command applied during that step (`BridgeLog.actions_at`: the commands the robot reported
    applying where the log holds them, else those sent); with the commands in force during the
    LEAD_STEPS steps before the run as its lead_actions."""
    from judo.ros2.mcap_read import read_bridge_log

    log = read_bridge_log(path, task_name, "python -m judo sysid LOG.mcap")
    step = float(model.opt.timestep)
    episodes = []
    for rows, offsets in log.grid_runs(step):
        qpos = np.full((offsets[-1] + 1, model.nq), np.nan)
        qvel = np.full((offsets[-1] + 1, model.nv), np.nan)
        qpos[offsets], qvel[offsets] = log.qpos[rows], log.qvel[rows]
        actions = log.actions_at(
            log.times[rows.start] + np.arange(-LEAD_STEPS, offsets[-1] + 1) * step
        )
        name = f"{path.name}:rows {rows.start}-{rows.stop - 1}"
        lead = actions[:LEAD_STEPS]
        episodes.append(
            Episode(name, qpos, qvel, actions[LEAD_STEPS:], lead_actions=lead, commands=log.source)
        )
    return episodes


def commands_line(episodes: list[Episode]) -> str:
    """The report's line on which commands each step was paired with, by how many episodes each."""
    said = {
        "applied": "the commands the robot reported applying, "
        "logged on its side, exact however late "
        "they came",
        "sent": "the commands the bridge sent, as the log "
        "holds none the robot reported applying: a "
        "command that "
        "came late is the command delay's to model",
        "served": "the actions the plant was served, in process",
    }
    counts = {kind: sum(e.commands == kind for e in episodes) for kind in said}
    parts = [
        f"{said[kind]} ({n} episode{'' if n == 1 else 's'})" for kind, n in counts.items() if n
    ]
    return "Commands: each step paired with " + "; ".join(parts) + "."
