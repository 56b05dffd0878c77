"""The plant interface (simulator or hardware), its MuJoCo implementation, and the one gate every
call into it goes through.

Controller and GUI code only ever talk to a `System`, so a user swaps the simulator for a robot by
writing one subclass: read the state, apply an action, step.

**The gate** (`SystemCalls`): which call is in flight and since when, and none after a stop. A
robot's driver may block or raise. The closed loop makes each System call through `SystemCalls`, so
- the app can see a call that has blocked for too long (`blocked`) and report it, or halt the robot;
- once `close()` has returned, no System call starts any more (a call already in flight may still
  end);
- each call fails on its own: the caller decides what a failed call means for the others.
"""

import threading
import time
from abc import ABC, abstractmethod
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError
from judo.core.reading import SystemState
from judo.core.task import Task, new_task
from judo.loop.mujoco_warnings import count_mujoco_warnings
from judo.loop.records import Recorder

DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)
"""MuJoCo warnings that mean the simulation blew up (it resets the data itself on bad qpos/qvel)."""

PLANT_STREAM = 0x706C616E74
"""Second word of a simulated plant's seed sequence, keeping its stream apart from the controller's
generators."""


class SimulationDiverged(JudoError):
    """The plant's state became non-finite or MuJoCo flagged bad positions, velocities or
    accelerations; the plant was reset."""


class System(ABC):
    """A plant the controller drives. `timestep` is the seconds one `step()` advances."""

    timestep: float

    @abstractmethod
    def reset(self) -> None:
        """Put the plant in its start state."""

    @abstractmethod
    def read_state(self) -> SystemState:
        """The latest state; the arrays are copies the caller may keep."""

    @abstractmethod
    def apply(self, action: np.ndarray) -> None:
        """Command the (task.command_size,) `action` from now on: the actuators' ctrl, or, for a
        task with a low-level policy, its command, which the robot's own controller turns into ctrl
        at its rate."""

    @abstractmethod
    def step(self) -> None:
        """Advance the plant by `timestep` under the last applied action."""

    def halt(self) -> bool:
        """Bring the robot to rest now, e.g. engage brakes or switch the drives to a hold mode;
        called on a pause, a stop and a watchdog trip, possibly from another thread than `step`.
        Return True if done; the default returns False, and the app then applies the task's
        `safe_action` instead."""
        return False

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        """Move the task's goal `index` (mocap body `index`) to `position` (3,), turned to the unit
        `quat` (4,) wxyz if given, before the next step; the next reading's metadata carries it back
        ("mocap_pos", "mocap_quat"). The default refuses: a System that can move its goals (a
        simulator, a bridge with a goal topic) says how."""
        raise JudoError(
            f"{type(self).__name__} cannot move goals: it does not implement System.move_goal"
        )

    def recorder(self) -> Recorder | None:
        """The System's own recorder of the closed loop's plans and steps (the ROS 2 bridge's MCAP
        log of each limit hit), which a ClosedLoop on it adds to its recorders; None by default."""
        return None

    def plant_sensors(self) -> np.ndarray:
        """(nsensordata,) every sensor value of the plant, for logs and datasets; empty by default
        (a robot has no simulator sensors to give)."""
        return np.zeros(0)

    def plant_state(self) -> np.ndarray | None:
        """(nq + nv,) the plant's true state for logs and metrics, where the System knows it (a
        simulator); None by default (a robot knows only what it measures)."""
        return None


class MujocoSystem(System):
    """Simulates `task.sim_model` in `task.data`, calling the task's sim hooks around each step.

    The plant is the System's: the task instance it steps is its own, never the controller's. For a
    task with a low-level policy (`Task.low_level`), `apply` serves the command and the plant runs
    the policy on it every k steps before stepping (`LowLevelPlant`), as the robot's own controller
    would. `MujocoSystem.from_task` builds the simulated plant for the app, evaluate, tune and the
    benchmarks.
    """

    def __init__(self, task: Task) -> None:
        self.task = task
        self.timestep = float(task.sim_model.opt.timestep)
        self._scratch: mujoco.MjData | None = None  # for sensor_values
        low_level = task.low_level()
        # a LowLevelPlant
        self.low_level = None if low_level is None else low_level.plant(task.sim_model)
        # a diverging plant warns every step: one counting line every few seconds instead
        count_mujoco_warnings()

    @classmethod
    def from_task(cls, task: Task, seed: int | None = None) -> "MujocoSystem":
        """The simulated plant of `task`: a new instance of its class sharing its config, reset to
        its start, with `task.plant_overrides` set on its plant model (never `task.model_overrides`:
        the plant is the MJCF's).

        The one seeding rule of every simulated plant: the plant's `rng` is seeded with [seed,
        PLANT_STREAM] (a stream apart from the controller's), so the same seed gives the same
        randomised start state; `seed` None draws a fresh one. The class must be constructible with
        no arguments, as every registered task is.
        """
        plant: Task = new_task(type(task))
        # only the plant's: the planning model's overrides are the controller's
        if task.plant_overrides:
            from judo.core.configuration.model_overrides import override_task_models

            override_task_models(plant, {}, task.plant_overrides)
        plant.config = task.config
        plant.rng = np.random.default_rng(None if seed is None else [seed, PLANT_STREAM])
        plant.reset()
        if cls is MujocoSystem:  # the task answers which simulated plant it needs
            return SIMULATORS[plant.simulator](plant)
        return cls(plant)

    def plant_sensors(self) -> np.ndarray:
        return self.task.data.sensordata.copy()

    def plant_state(self) -> np.ndarray:
        return np.concatenate([self.task.data.qpos, self.task.data.qvel])

    def reset(self) -> None:
        self.task.reset()
        if self.low_level is not None:
            self.low_level.reset()

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        self.task.data.mocap_pos[index] = position
        if quat is not None:
            self.task.data.mocap_quat[index] = quat / np.linalg.norm(quat)

    def read_state(self) -> SystemState:
        data = self.task.data
        metadata = {"mocap_pos": data.mocap_pos.copy(), "mocap_quat": data.mocap_quat.copy()}
        metadata.update(self.task.get_sim_metadata())
        return SystemState(np.concatenate([data.qpos, data.qvel]), float(data.time), metadata)

    def sensor_values(self) -> np.ndarray:
        """(task.sim_measured.size,) the task's measured sensors at the plant's current state,
        noiseless.

        Evaluated on a scratch MjData (`mj_forward` on a copy of the state), so the plant's own
        data, and with it the solver's warm start, is untouched: sensing never changes the physics.
        (After `mj_step` the plant's sensordata belongs to the state before the step.)
        """
        model = self.task.sim_model
        scratch = self._scratch = self._scratch or mujoco.MjData(model)
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, self.task.data, state, spec)
        mujoco.mj_setState(model, scratch, state, spec)
        mujoco.mj_forward(model, scratch)
        return self.task.sim_measured.read(scratch.sensordata)

    def apply(self, action: np.ndarray) -> None:
        if self.low_level is not None:
            self.low_level.command[:] = action
        else:
            self.task.data.ctrl[:] = action

    def step(self) -> None:
        """One physics step. Raises SimulationDiverged (after resetting the task) if the state blew
        up."""
        model, data = self.task.sim_model, self.task.data
        start_time = data.time  # MuJoCo's own reset on bad qpos/qvel zeroes data.time
        self.task.pre_sim_step()
        if self.low_level is not None:
            self.low_level.before_step(model, data)
        mujoco.mj_step(model, data)
        self.task.post_sim_step()
        warnings = [data.warning[w] for w in DIVERGENCE_WARNINGS]
        if any(w.number for w in warnings) or not (
            np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
        ):
            for warning in warnings:
                warning.number = 0
            self.task.reset()
            if self.low_level is not None:
                self.low_level.reset()
            data.time = start_time + model.opt.timestep  # the plant's clock keeps running
            raise SimulationDiverged(
                f"simulation of {type(self.task).__name__} diverged at t={start_time:.3f} s; "
                "reset the task"
            )


def missing_halt(system: System) -> str | None:
    """The start-up warning for a user System without its own `halt()`, or None when it has one."""
    if type(system).halt is not System.halt:
        return None
    return (
        f"your System {type(system).__name__} defines no halt(): while a call into it "
        "blocks, nothing reaches the "
        "robot, which keeps its last action until the call returns; define halt() to bring "
        "it to rest from another "
        "thread (docs/hardware.md)"
    )


class DynamicsSystem(MujocoSystem):
    """The simulated plant of a DynamicsTask: steps the task's own `dynamics` on one row, seeded,
    with optional process noise, instead of MuJoCo's physics.

    The state x lives in the task's carrier `data` ([qpos, qvel], judo.core.rollouts.dynamics), so
    reading the state, logs, datasets and the GUI work as for any MuJoCo plant.
    `MujocoSystem.from_task` builds one for a task whose `simulator` is "dynamics".

    Args:
        task: the plant's own DynamicsTask instance, reset to its start.
        process_noise: (nx,) or scalar standard deviation of the Gaussian noise added to x after
            each step, drawn from `task.rng` (seeded by `from_task`); None: the task's
            `process_noise`.
    """

    def __init__(self, task: Task, process_noise: float | np.ndarray | None = None) -> None:
        if task.simulator != "dynamics":
            raise ConfigError(
                f"{type(self).__name__} needs a task that is a DynamicsTask, got "
                f"{type(task).__name__}"
            )
        super().__init__(task)
        own: Any = task  # a DynamicsTask: its nx, state, step_checked, trace_points, process_noise
        self.dynamics_task = own
        noise = own.process_noise if process_noise is None else process_noise
        self.process_noise = np.broadcast_to(np.asarray(noise, dtype=float), (own.nx,)).copy()
        self._low, self._high = task.actuator_ctrlrange.T.copy()

    def step(self) -> None:
        """One step of the task's dynamics under the applied control. Raises SimulationDiverged
        (after resetting the task) when the state turns non-finite."""
        task, data = self.dynamics_task, self.dynamics_task.data
        start_time = data.time
        task.pre_sim_step()
        # as MuJoCo clamps a limited actuator's ctrl
        control = np.clip(data.ctrl, self._low, self._high)
        x = task.step_checked(task.state[None], control[None])[0]
        if self.process_noise.any():
            x = x + self.process_noise * task.rng.standard_normal(task.nx)
        task.state = x
        # the carrier's only sensors: the traced points
        data.sensordata[:] = task.trace_points(x).ravel()
        data.time = start_time + task.dt
        task.post_sim_step()
        if not np.isfinite(x).all():
            task.reset()
            data.time = start_time + task.dt  # the plant's clock keeps running
            raise SimulationDiverged(
                f"{type(task).__name__}.dynamics gave a non-finite state at "
                f"t={start_time:.3f} s; reset the task"
            )


SIMULATORS: dict[str, type[MujocoSystem]] = {"mujoco": MujocoSystem, "dynamics": DynamicsSystem}
"""The simulated plant of each `Task.simulator`: MuJoCo's physics, or a DynamicsTask's own
dynamics."""


class SystemClosedError(JudoError):
    """The app stopped: no System call starts any more."""


class SystemCallError(JudoError):
    """Some System calls of one plant step failed; each was tried on its own.

    Attributes:
        failed: {call name: its exception}, of "apply", "step" and "read_state".
    """

    def __init__(self, failed: dict[str, Exception]) -> None:
        self.failed = failed
        super().__init__(
            "; ".join(
                f"system {name} failed: {type(err).__name__}: {err}" for name, err in failed.items()
            )
        )

    @property
    def served(self) -> bool:
        """Whether the plant still got its action and its step."""
        return "apply" not in self.failed and "step" not in self.failed


class SystemReadingError(JudoError, TypeError):
    """A System's `read_state()` returned something other than a SystemState."""


def check_reading(system: System, reading: Any) -> SystemState:
    """`reading`, which `system.read_state()` returned, if it is a SystemState; else
    SystemReadingError (one line, naming the System's class, the method and the expected type)."""
    if not isinstance(reading, SystemState):
        raise SystemReadingError(
            f"{type(system).__name__}.read_state() returned {type(reading).__name__}; "
            "expected a judo.SystemState "
            "(state, time, metadata, sensors)"
        )
    return reading


class SystemCalls:
    """Makes calls into `system` one gate at a time; safe to use from several threads.

    Attributes:
        system: the System called.
        in_flight: (name, monotonic start time) of the call under way, or None.
    """

    def __init__(self, system: System) -> None:
        self.system = system
        self.in_flight: tuple[str, float] | None = None
        self._gate = threading.Lock()
        self._closed = False

    def _call(self, name: str, *args: Any) -> Any:
        with self._gate:
            if self._closed:
                raise SystemClosedError(f"the app has stopped; System.{name} was not called")
            self.in_flight = (name, time.monotonic())
        try:
            return getattr(self.system, name)(*args)
        finally:
            self.in_flight = None

    def read_state(self) -> SystemState:
        return check_reading(self.system, self._call("read_state"))

    def apply(self, action: np.ndarray) -> None:
        self._call("apply", action)

    def step(self) -> None:
        self._call("step")

    def reset(self) -> None:
        self._call("reset")

    def halt(self) -> bool:
        """The System's `halt()`: True if it brought the robot to rest itself."""
        return bool(self._call("halt"))

    def offers_halt(self) -> bool:
        """Whether the System overrides `halt` (the default does nothing and returns False)."""
        return type(self.system).halt is not System.halt

    def blocked(self, limit: float) -> tuple[str, float] | None:
        """(name, seconds) of the call under way if it has run longer than `limit` seconds, else
        None."""
        in_flight = self.in_flight
        if in_flight is None:
            return None
        seconds = time.monotonic() - in_flight[1]
        return (in_flight[0], seconds) if seconds > limit else None

    def close(self) -> None:
        """Let no call start any more; returns at once (a call in flight is not waited for)."""
        with self._gate:
            self._closed = True

    @property
    def closed(self) -> bool:
        """Whether `close()` was called."""
        return self._closed
