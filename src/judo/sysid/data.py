"""The data a sysid fit reads: logged episodes (judo's HDF5 logs and the ROS 2 bridge's MCAP) and
the K-step windows cut from them, with the actions before each (for a fitted delay) and the
prediction error over them.

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
from judo.core.sensors import MeasuredLayout
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
    steps of `model` apart with a command in force (`judo.ros2.mcap_read.BridgeLog.grid_runs`, whose
    errors name the file), laid on the model's step grid: a row every step, its state NaN where no
    joint state fell on it (a robot that publishes every k steps) and its action the command applied
    during that step (`BridgeLog.actions_at`: the commands the robot reported applying where the log
    holds them, else those sent); with the commands in force during the LEAD_STEPS steps before the
    run as its lead_actions."""
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


@dataclass
class Windows:
    """K-step windows cut from the episodes: each rolled out from its start state under its logged
    actions.

    Attributes:
        starts: (W, nq + nv) the state each window starts from: the logged state before its first
            step, or, when comparing sensors, the logged estimate there where the log has one.
        controls: (W, K, nu) actions served during the window's steps.
        measured: (W, K, D) what the model's prediction is compared with: comparing states, the
            logged state after each of the window's steps (D = nq + nv; NaN where none was logged);
            comparing sensors, the measured sensors taken at the window's start and after each of
            its first K - 1 steps (D = m; NaN where no value was taken then).
        history: (W, H, nu) actions served during the H steps before the window (H = 0 unless a
            delay is fitted).
        compare: "states" or "sensors".
        columns: (m,) the columns of sensordata the measured sensors are, when comparing sensors;
            else None.
        from_estimate: whether the windows start from the logged estimate (else from the logged
            states).
    """

    starts: np.ndarray
    controls: np.ndarray
    measured: np.ndarray
    history: np.ndarray
    compare: str = "states"
    columns: np.ndarray | None = None
    from_estimate: bool = False


def cut_windows(
    episodes: list[Episode],
    steps: int,
    history: int = 0,
    compare: str = "states",
    layout: MeasuredLayout | None = None,
    timestep: float = 0.0,
    shift: int = 0,
    reserve: int = 0,
) -> Windows:
    """Non-overlapping windows of `steps` steps from every episode, each with the `history` actions
    before it (an episode's first row is a window's start only, since the state before it is not
    logged). A window starts at a row with a logged state: where a row has none (a robot that
    reports every k steps), the next one is tried.

    `shift` is a command delay in steps: the action applied during each step is the one served
    `shift` steps before it. Every window needs the `reserve` (at least `shift`) + `history` actions
    served before it (from the episode's lead_actions where it has them), so that fits of each shift
    up to `reserve` compare the same windows.

    `compare` "states" compares the logged states. "sensors" compares the measured sensors, laid out
    as `layout` (the planning model's measured sensors) says, each value placed at the step it was
    taken (its logged age over `timestep`); each window starts from the logged estimate where the
    episode has one, else from the logged state. A window without a finite start state, or with
    nothing to compare, is left out. ConfigError where no window is left, or the log's measured
    sensors are not the task's."""
    starts, controls, measured, before = [], [], [], []
    from_estimate = False
    reserve = max(reserve, shift)
    nu = episodes[0].actions.shape[1]
    for episode in episodes:
        states = episode.states
        if compare == "sensors":
            assert layout is not None and timestep > 0
            # (S + 1, m): index n is after n steps
            targets = taken_samples(episode, layout, timestep)
            if episode.estimate is not None and np.isfinite(episode.estimate).all(axis=1).any():
                states, from_estimate = episode.estimate, True
        lead = np.zeros((0, nu)) if episode.lead_actions is None else episode.lead_actions
        # row len(lead) + i: the action served during step i
        actions = np.concatenate([lead, episode.actions])
        first = 1 + max(0, reserve + history - len(lead))
        while first <= len(states) - steps:
            start = states[first - 1]
            # a step without a logged state: the next one may start a window
            if not np.isfinite(start).all():
                first += 1
                continue
            target = (
                targets[first : first + steps]
                if compare == "sensors"
                else states[first : first + steps]
            )
            row = len(lead) + first
            applied = actions[row - shift - history : row - shift + steps]  # (history + steps, nu)
            if (
                not np.isnan(target).all()
                and np.isfinite(actions[row - reserve - history : row + steps]).all()
            ):
                starts.append(start)
                controls.append(applied[history:])
                measured.append(target)
                before.append(applied[:history])
            first += steps
    if not starts:
        longest = max((len(e.qpos) for e in episodes), default=0)
        raise ConfigError(
            f"no window of {steps} steps (after {history + reserve} steps of action history) "
            "with a logged start "
            "state and something to compare fits the logs (the longest episode has "
            f"{longest} steps)"
        )
    return Windows(
        np.array(starts),
        np.array(controls),
        np.array(measured),
        np.array(before).reshape(len(starts), history, nu),
        compare,
        None if compare == "states" else np.asarray(layout.columns) if layout is not None else None,
        from_estimate,
    )


def taken_samples(episode: Episode, layout: MeasuredLayout, timestep: float) -> np.ndarray:
    """(S + 1, m) the episode's measured sensor values by the step they were taken at: row n holds
    the values taken after n steps (row 0 at the start), NaN where none was. A value read after step
    i with age a was taken round(a / timestep) steps earlier; a value held over several readings
    lands on the same row each time. ConfigError where the log's measured sensors are not
    `layout`'s."""
    assert episode.measured is not None
    if episode.measured_sensors and tuple(episode.measured_sensors) != tuple(layout.names):
        raise ConfigError(
            f"{episode.name}: measured sensors {list(episode.measured_sensors)}, but the "
            "task measures "
            f"{list(layout.names)}"
        )
    if episode.measured.shape[1] != layout.size:
        raise ConfigError(
            f"{episode.name}: {episode.measured.shape[1]} measured values a step, the task's "
            "measured sensors "
            f"have {layout.size}"
        )
    rows = len(episode.measured)
    samples = np.full((rows + 1, layout.size), np.nan)
    age = (
        np.zeros((rows, len(layout.names)))
        if episode.measured_age is None
        else episode.measured_age
    )
    for sensor, columns in enumerate(layout.slices):
        ages = np.nan_to_num(age[:, sensor], nan=np.inf)
        taken = np.arange(1, rows + 1) - np.round(ages / timestep)
        valid = (
            np.isfinite(taken)
            & (taken >= 0)
            & np.isfinite(episode.measured[:, columns]).all(axis=1)
        )
        samples[taken[valid].astype(int), columns] = episode.measured[valid, columns]
    return samples


def delayed_controls(windows: Windows, delay: float, timestep: float) -> np.ndarray:
    """(W, K, nu) the control in force during each window's steps when every logged action takes
    effect `delay` seconds late: the logged actions (piecewise constant, one per step) read at t -
    delay, interpolated linearly between steps (so the residual is continuous in the delay). `delay`
    is at most H steps of `windows.history`."""
    if delay <= 0.0:
        return windows.controls
    history = windows.history.shape[1]
    extended = np.concatenate([windows.history, windows.controls], axis=1)  # (W, H + K, nu)
    # fractional row of each step's control
    at = history + np.arange(windows.controls.shape[1]) - delay / timestep
    low = np.clip(np.floor(at).astype(int), 0, extended.shape[1] - 1)
    high = np.clip(low + 1, 0, extended.shape[1] - 1)
    fraction = (at - np.floor(at))[None, :, None]
    return (1.0 - fraction) * extended[:, low] + fraction * extended[:, high]


def prediction_residuals(model: mujoco.MjModel, windows: Windows, delay: float = 0.0) -> np.ndarray:
    """(W, K, D) `model`'s K-step predictions (under the logged actions `delay` seconds late) less
    what the windows compare (the logged states, or the measured sensors where a value was taken;
    NaN where nothing was), each coordinate divided by its spread in the log (so angles, positions
    and velocities weigh alike)."""
    from mujoco import rollout

    state_size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    initial = np.zeros((len(windows.starts), state_size))
    data = mujoco.MjData(model)
    for row, start in enumerate(windows.starts):
        data.qpos[:], data.qvel[:] = start[: model.nq], start[model.nq :]
        mujoco.mj_getState(model, data, initial[row], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    controls = delayed_controls(windows, delay, float(model.opt.timestep))
    states, sensordata = rollout.rollout(model, data, initial, controls)
    if windows.columns is not None:  # sensordata row j: the sensors of the state after j steps
        predicted = sensordata[..., windows.columns]
    else:
        # rows are [time, qpos, qvel, ...]
        qpos_at = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)
        predicted = states[..., qpos_at : qpos_at + model.nq + model.nv]
    return (predicted - windows.measured) / spread(windows)


def prediction_error(model: mujoco.MjModel, windows: Windows, delay: float = 0.0) -> float:
    """RMS over windows, steps and coordinates of `prediction_residuals` where something was
    compared."""
    return rms(prediction_residuals(model, windows, delay))


def rms(residuals: np.ndarray) -> float:
    """The RMS of the finite entries of `residuals` (any shape)."""
    return float(np.sqrt(np.nanmean(np.square(residuals))))


def spread(windows: Windows) -> np.ndarray:
    """(D,) the standard deviation of each compared coordinate over the logged windows (1 where it
    never moves)."""
    flat = windows.measured.reshape(-1, windows.measured.shape[-1])
    spread = np.array(
        [
            np.std(column[np.isfinite(column)]) if np.isfinite(column).any() else 0.0
            for column in flat.T
        ]
    )
    return np.where(spread > 1e-9, spread, 1.0)
