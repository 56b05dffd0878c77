"""How `python -m judo excite` (judo.sysid.excite) drives a plant: controls served one per step of a
System, open loop, what it reports after each logged, and the plant brought to rest at the end.
"""

import signal
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from judo.core.commandline.interrupts import sigint_as_flag

if TYPE_CHECKING:
    from judo.core.reading import SystemState
    from judo.core.task import Task
    from judo.loop.system import System
    from judo.loop.timing import PlantClock

STOP_POLL = 0.05
"""Most seconds `sleep_until_due` sleeps before it asks again whether to stop."""


@dataclass
class Excited:
    """What `drive` logged of the plant, one row per step it completed.

    Attributes:
        states: (S, nq + nv) the plant's state after each step: its true state where it knows it (a
            simulator), else its reading's; NaN rows where it reported none (a robot that measures
            only sensors).
        sensors: (S, nsensordata) every sensor of the plant after each step, NaN where it has none
            to give.
        measured: (S, m) the task's measured sensors the reading held, or None where it held none.
        measured_age: (S, k) seconds between taking each measured sensor's value and the end of its
            step.
        estimate: (S, nq + nv) the estimator's state after each step, or None where no estimator
            ran.
        stopped: whether a stop request (Ctrl-C, SIGTERM) ended the run early.
        halted: how the plant was brought to rest at the end: "halted it (halt())" or the task's
            safe action.
    """

    states: np.ndarray
    sensors: np.ndarray
    measured: np.ndarray | None
    measured_age: np.ndarray | None
    estimate: np.ndarray | None
    stopped: bool
    halted: str

    @property
    def steps(self) -> int:
        """S, the steps completed."""
        return len(self.states)

    @property
    def has_states(self) -> bool:
        """Whether the plant reported its state."""
        return bool(np.isfinite(self.states).all(axis=1).any())

    def measurements(self, task: "Task") -> "Measurements | None":
        """The measured sensors, their ages and the estimate, for `excitation_episode`; None where
        none was read."""
        if self.measured is None:
            return None
        return Measurements(
            self.measured, self.measured_age, self.estimate, tuple(task.measured_sensors)
        )


@dataclass
class Measurements:
    """A System's measured sensors (S, m), their ages (S, k) or None, the estimate (S, nq + nv) or
    None, and the measured sensors' names (k,): what `excitation_episode` logs beside the states."""

    measured: np.ndarray
    measured_age: np.ndarray | None
    estimate: np.ndarray | None
    names: tuple[str, ...]


def drive(
    system: "System",
    task: "Task",
    task_name: str,
    controls: np.ndarray,
    paced: bool = False,
    on_step: Callable[[int], None] | None = None,
) -> Excited:
    """Serve `controls` (S, nu), one per step of `system` (`paced`: step k when the app's plant
    clock says, at wall time k * timestep from the first; else as fast as it goes), and log what it
    reports after each step: its state (`plant_state()`, else the reading's), its sensors
    (`plant_sensors()`), the measured sensors of its reading with their ages, and, where the reading
    holds no state, the state `task`'s default estimator makes of them (`choose_estimator`, as the
    app picks it). A stop request (Ctrl-C, SIGTERM) ends the run after the step under way; at the
    end, stopped or not, or on an error, the plant is brought to rest: its `halt()`, else the task's
    `safe_action` from the last state known. `on_step(steps done)` is called after each step (a
    progress display)."""
    from judo.core.estimator import ControlHistory
    from judo.evaluation.sensing import Sensing, choose_estimator
    from judo.loop.system import check_reading
    from judo.loop.timing import PlantClock

    model = task.model
    width = model.nq + model.nv
    steps, k = len(controls), len(task.measured_sensors)
    reading = check_reading(system, system.read_state())
    _, estimator = choose_estimator(task, task_name, system, Sensing(), reading)
    history = ControlHistory(model.nu)
    states = np.full((steps, width), np.nan)
    sensors = np.full((steps, model.nsensordata), np.nan)
    measured = np.full((steps, task.measured.size), np.nan)
    ages = np.full((steps, k), np.nan)
    estimate = np.full((steps, width), np.nan)
    last_state = np.concatenate([model.qpos0, np.zeros(model.nv)])
    any_measured, done = False, 0
    clock = PlantClock()
    with sigint_as_flag((signal.SIGINT, signal.SIGTERM)) as stop:
        try:
            for step, control in enumerate(controls):
                if stop or (
                    paced and not sleep_until_due(clock, system.timestep, lambda: bool(stop))
                ):
                    break
                history.append(_now(system, reading), control)
                system.apply(control)
                system.step()
                clock.stepped(1)
                reading = check_reading(system, system.read_state())
                now = _now(system, reading)
                true = system.plant_state()
                state = true if true is not None else reading.state
                if state is not None:
                    states[step] = state
                every = system.plant_sensors()
                if every.shape == (model.nsensordata,):
                    sensors[step] = every
                if reading.sensors is not None and np.shape(reading.sensors) == (
                    task.measured.size,
                ):
                    any_measured = True
                    measured[step] = reading.sensors
                    stamps = reading.metadata.get("sensor_times", reading.time)
                    ages[step] = now - np.broadcast_to(np.asarray(stamps, dtype=float), (k,))
                if estimator is not None:
                    estimate[step] = estimator.update(reading, now, history).state
                known = estimate[step] if estimator is not None else states[step]
                if np.isfinite(known).all():
                    last_state = known
                done = step + 1
                if on_step is not None:
                    on_step(done)
        finally:
            halted = halt(system, task, last_state)
    return Excited(
        states[:done],
        sensors[:done],
        measured[:done] if any_measured else None,
        ages[:done] if any_measured else None,
        estimate[:done] if estimator is not None else None,
        bool(stop),
        halted,
    )


def sleep_until_due(clock: "PlantClock", timestep: float, stopped: Callable[[], bool]) -> bool:
    """Sleep until `clock` has a step of `timestep` s due (True), or until `stopped()` (False),
    asking it at least every STOP_POLL s: the wait of a loop that steps one step at a time."""
    while not stopped():
        now = time.perf_counter()
        if clock.due(now, timestep):
            return True
        time.sleep(min(clock.wait(now, timestep), STOP_POLL))
    return False


def halt(system: "System", task: "Task", state: np.ndarray) -> str:
    """Bring `system` to rest: its `halt()`, else `task.safe_action(state)` applied; says which."""
    if system.halt():
        return "halted it (halt())"
    system.apply(task.safe_action(state))
    return "applied the task's safe action"


def _now(system: "System", reading: "SystemState") -> float:
    """The plant's now: the System's `time` where it has one (its readings may be late), else the
    reading's."""
    now = getattr(system, "time", None)
    return float(now) if isinstance(now, int | float) else float(reading.time)
