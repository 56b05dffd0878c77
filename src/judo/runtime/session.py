"""What the app runs at one moment: a task and optimizer by name, their Controller, the plant, and the
closed loop between them.

Switching task or optimizer builds a new Session and closes the old one; nothing is patched in place.
"""

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.config import require
from judo.core.controller import ControllerConfig
from judo.core.errors import ConfigError
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig, ReadingError, default_estimator_name
from judo.core.optimizer import OptimizerConfig
from judo.core.planner import Planner
from judo.core.policy import Policy
from judo.core.policy_controller import make_policy_controller
from judo.core.registry import lookup_estimator, make_controller, make_estimator
from judo.core.task import Task, TaskConfig
from judo.runtime.closed_loop import ClosedLoop
from judo.runtime.estimator_thread import EstimatorThread
from judo.runtime.sensing import PerType, SensedSystem
from judo.runtime.system import MujocoSystem, System, SystemState
from judo.runtime.system_calls import check_reading

Observe = Literal["state", "sensors"]
"""What the simulated plant serves: its full state, or only the task's measured sensors (rehearsed sensing)."""
OBSERVE_CHOICES = ("state", "sensors")
POLICY_OPTIMIZER = "policy"
"""The optimizer name of a session that a policy drives instead of an optimizer (`App(policy=...)`)."""
SENSING_STREAM = 0x73656E7365
"""Second entry of the sensor noise's seed sequence ([seed, SENSING_STREAM]): a stream apart from the plant's."""


@dataclass(frozen=True)
class Sensing:
    """How the app's simulated plant is observed, kept across switches.

    Attributes:
        observe: "state" (the full state) or "sensors" (the measured sensors through `SensedSystem`).
        noise, delay, rate: `SensedSystem`'s per-type settings (std, seconds, Hz), for observe="sensors".
        estimator: registered estimator name; None picks by the first reading (`default_estimator_name`).
        estimator_config: its config; None takes the registered defaults (with the task's overrides).
    """

    observe: Observe = "state"
    noise: PerType = None
    delay: PerType = None
    rate: PerType = None
    estimator: str | None = None
    estimator_config: EstimatorConfig | None = None

    def check(self) -> None:
        """Raise ConfigError for an unknown observe or a config of another estimator; UnknownNameError
        (listing the valid names) for an unregistered estimator."""
        require(
            self.observe in OBSERVE_CHOICES, f"observe must be one of {list(OBSERVE_CHOICES)}, got {self.observe!r}"
        )
        if self.estimator is not None:
            _, config_cls = lookup_estimator(self.estimator)
            if self.estimator_config is not None:
                require(
                    isinstance(self.estimator_config, config_cls),
                    f"estimator_config for {self.estimator!r} must be a {config_cls.__name__}, "
                    f"got {type(self.estimator_config).__name__}",
                )


@dataclass
class Session:
    """A controller, its plant and the closed loop between them.

    Attributes:
        task_name, optimizer_name: registry names.
        controller: the Planner (a Controller, or a PolicyController where a policy drives); plans on its own Task
            instance (`controller.task`).
        system: the plant; a MujocoSystem simulating its own task instance (behind a SensedSystem when
            observing sensors), or the user's own System.
        closed_loop: the one closed-loop step on `controller` and `system`.
        estimator_name: the estimator the closed loop runs (`closed_loop.estimator`), or None when it plans
            from the System's full-state readings as they are.
        generation: counts sessions within one app, so stale GUI edits and snapshots are recognised.
    """

    task_name: str
    optimizer_name: str
    controller: Planner
    system: System
    closed_loop: ClosedLoop
    generation: int
    estimator_name: str | None = None

    @property
    def simulated(self) -> MujocoSystem | None:
        """The plant when it is the app's own simulation (goals can be moved, configs shared), else None;
        the simulator itself when it is observed through a SensedSystem."""
        system = self.system.system if isinstance(self.system, SensedSystem) else self.system
        return system if isinstance(system, MujocoSystem) else None

    def close(self) -> None:
        """Stop the controller's rollout threads, and the estimator's thread where it runs on one."""
        if isinstance(self.closed_loop.estimator, EstimatorThread):
            self.closed_loop.estimator.close()
        self.controller.close()


def build_session(
    task_name: str,
    optimizer_name: str,
    generation: int,
    *,
    controller_config: ControllerConfig | None = None,
    optimizer_config: OptimizerConfig | None = None,
    task_config: TaskConfig | None = None,
    system: System | None = None,
    seed: int | None = None,
    num_workers: int | None = None,
    backend: str = "cpu",
    clock: Callable[[], float] | None = None,
    on_watchdog: Callable[[str | None], None] | None = None,
    sensing: Sensing | None = None,
    reading: SystemState | None = None,
    estimator_thread: bool = False,
    proposal_policy: Policy | None = None,
    policy: Policy | None = None,
) -> Session:
    """A new Session. Configs left out get the task's registered defaults.

    With no `system`, the plant is `MujocoSystem.from_task` of the controller's task (its config shared,
    seeded by `seed`, at its start state). A given `system` is kept as it is, e.g. the user's hardware or
    the running plant when only the optimizer changes. `backend` names the controller's rollout backend;
    `clock` and `on_watchdog` go to the closed loop (its watchdog's clock, and its trip/recovery callback).

    `sensing` says how a new simulated plant is observed (observe="sensors" wraps it in a SensedSystem whose
    noise draws from [seed, SENSING_STREAM]) and which estimator the closed loop runs: the named one, else
    the task's `default_estimator` when the plant's first reading has no full state, else none (plan from the reading as it is).
    `reading` is the given `system`'s latest reading, when another thread is driving it (a switch); None
    reads it here. `proposal_policy` makes the controller's `policy_samples` candidates (judo.core.proposals;
    PolicyError unless it fits the task). `policy` drives the plant instead of an optimizer (`optimizer_name` is then
    POLICY_OPTIMIZER and `optimizer_config` unused; `controller_config` None takes the policy's metadata's rate).
    `estimator_thread` runs the estimator on a thread of its own (`EstimatorThread`), for the
    app's plant thread, which must not wait for the filter; evaluate's sim-time episodes leave it off.
    Raises UnknownNameError for an unregistered name and ConfigError for configs that do not work together
    (e.g. observing sensors on a task that declares none, or an estimator that cannot fuse the plant's readings).
    """
    sensing = sensing if sensing is not None else Sensing()
    sensing.check()
    if policy is not None:  # the policy is the controller (judo.core.policy_controller); the loop is the same
        controller: Planner = make_policy_controller(task_name, policy, controller_config=controller_config, seed=seed)
    else:
        controller = make_controller(
            task_name,
            optimizer_name,
            controller_config=controller_config,
            optimizer_config=optimizer_config,
            num_workers=num_workers,
            seed=seed,
            backend=backend,
            proposal_policy=proposal_policy,
        )
    if task_config is not None:
        controller.task.config = task_config
    try:
        if system is None:
            system = observed_plant(controller.task, seed, sensing)
        name, estimator = choose_estimator(controller.task, task_name, system, sensing, reading)
        if estimator is not None and estimator_thread:
            estimator = EstimatorThread(estimator)
        closed_loop = ClosedLoop(controller, system, clock=clock, on_watchdog=on_watchdog, estimator=estimator)
    except BaseException:
        controller.close()
        raise
    return Session(task_name, optimizer_name, controller, system, closed_loop, generation, name)


def observed_plant(task: Task, seed: int | None, sensing: Sensing) -> MujocoSystem | SensedSystem:
    """The simulated plant of `task` (`MujocoSystem.from_task(task, seed)`), behind a SensedSystem serving
    only the measured sensors when `sensing.observe` is "sensors" (its noise drawn from [seed, SENSING_STREAM]).
    ConfigError for a task that declares no measured sensors."""
    plant = MujocoSystem.from_task(task, seed)
    if sensing.observe != "sensors":
        return plant
    rng = np.random.default_rng(None if seed is None else [seed, SENSING_STREAM])
    return SensedSystem(plant, sensing.noise, sensing.delay, sensing.rate, rng)


def choose_estimator(
    task: Task, task_name: str, system: System, sensing: Sensing, reading: SystemState | None = None
) -> tuple[str | None, Estimator | None]:
    """(name, estimator) between `system`'s readings and the plan: `sensing.estimator`, else the task's
    `default_estimator` for a plant whose readings have no full state, else (None, None) (plan from the reading
    as it is).

    `reading` is the plant's latest reading when another thread drives it; None reads it here. ConfigError
    when the estimator cannot fuse the plant's readings.
    """
    name = sensing.estimator
    if reading is None and (name is not None or not isinstance(system, MujocoSystem)):
        reading = check_reading(system, system.read_state())
    if name is None and not isinstance(system, MujocoSystem):  # the simulator reads its full state
        assert reading is not None
        name = default_estimator_name(reading, task)
        name = None if name == "state" else name
    if name is None:
        return None, None
    assert reading is not None
    config_cls = lookup_estimator(name)[1]
    if sensing.estimator is None and not isinstance(sensing.estimator_config, (config_cls, type(None))):
        raise ConfigError(  # a config given for another filter than the task's default
            f"estimator_config is a {type(sensing.estimator_config).__name__}, but {task_name}'s default "
            f"estimator {name!r} takes a {config_cls.__name__}; name the estimator it is for (estimator=...)"
        )
    estimator = make_estimator(name, task, sensing.estimator_config, task_name)
    check_estimator(name, estimator, reading)
    return name, estimator


def check_estimator(name: str, estimator: Estimator, reading: SystemState) -> None:
    """Raise ConfigError unless `estimator` can fuse the plant's `reading` (a filter of sensors on a full-state
    reading, or "state" on a sensors-only one, would fail at every step). Resets it."""
    try:
        estimator.reset(reading)
        estimator.update(reading, reading.time, ControlHistory(estimator.task.nu))
    except ReadingError as err:
        hint = " (observe='sensors' rehearses a robot's sensors in simulation)" if reading.sensors is None else ""
        raise ConfigError(f"the {name!r} estimator cannot run on this plant's readings: {err}{hint}") from None
