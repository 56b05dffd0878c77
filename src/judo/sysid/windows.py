"""The K-step windows a sysid fit cuts from logged episodes (judo.sysid.data), with the actions
before each (for a fitted delay), and a model's prediction error over them.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.errors import ConfigError
from judo.core.sensors import MeasuredLayout
from judo.sysid.data import Episode


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
