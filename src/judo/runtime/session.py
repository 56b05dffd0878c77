"""What the app runs at one moment: a task and optimizer by name, their Controller, the plant, and the
closed loop between them.

Switching task or optimizer builds a new Session and closes the old one; nothing is patched in place.
"""

from collections.abc import Callable
from dataclasses import dataclass

from judo.core.controller import Controller, ControllerConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.policy import Policy
from judo.core.policy_controller import make_policy_controller
from judo.core.registry import make_controller
from judo.core.task import TaskConfig
from judo.loop.closed_loop import ClosedLoop
from judo.loop.estimator_thread import EstimatorThread
from judo.loop.sensing import SensedSystem, Sensing, choose_estimator, observed_plant
from judo.loop.system import MujocoSystem, System, SystemState

POLICY_OPTIMIZER = "policy"
"""The optimizer name of a session that a policy drives instead of an optimizer (`App(policy=...)`)."""


@dataclass
class Session:
    """A controller, its plant and the closed loop between them.

    Attributes:
        task_name, optimizer_name: registry names.
        controller: plans on its own Task instance (`controller.task`).
        system: the plant; a MujocoSystem simulating its own task instance (behind a SensedSystem when
            observing sensors), or the user's own System.
        closed_loop: the one closed-loop step on `controller` and `system`.
        estimator_name: the estimator the closed loop runs (`closed_loop.estimator`), or None when it plans
            from the System's full-state readings as they are.
        generation: counts sessions within one app, so stale GUI edits and snapshots are recognised.
    """

    task_name: str
    optimizer_name: str
    controller: Controller
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
        made = make_policy_controller(task_name, policy, controller_config=controller_config, seed=seed)
        controller: Controller = made  # type: ignore[assignment]  # a PolicyController serves as one (duck-typed)
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
