"""What the app runs at one moment: a task and optimizer by name, their Controller, the plant, and the
closed loop between them.

Switching task or optimizer builds a new Session and closes the old one; nothing is patched in place.
"""

from collections.abc import Callable
from dataclasses import dataclass

from judo.core.controller import Controller, ControllerConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import make_controller
from judo.core.task import TaskConfig
from judo.runtime.closed_loop import ClosedLoop
from judo.runtime.system import MujocoSystem, System


@dataclass
class Session:
    """A controller, its plant and the closed loop between them.

    Attributes:
        task_name, optimizer_name: registry names.
        controller: plans on its own Task instance (`controller.task`).
        system: the plant; a MujocoSystem simulating its own task instance, or the user's own System.
        closed_loop: the one closed-loop step on `controller` and `system`.
        generation: counts sessions within one app, so stale GUI edits and snapshots are recognised.
    """

    task_name: str
    optimizer_name: str
    controller: Controller
    system: System
    closed_loop: ClosedLoop
    generation: int

    @property
    def simulated(self) -> MujocoSystem | None:
        """The plant when it is the app's own simulation (goals can be moved, configs shared), else None."""
        return self.system if isinstance(self.system, MujocoSystem) else None

    def close(self) -> None:
        """Stop the controller's rollout threads."""
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
) -> Session:
    """A new Session. Configs left out get the task's registered defaults.

    With no `system`, the plant is `MujocoSystem.from_task` of the controller's task (its config shared,
    seeded by `seed`, at its start state). A given `system` is kept as it is, e.g. the user's hardware or
    the running plant when only the optimizer changes. `backend` names the controller's rollout backend;
    `clock` and `on_watchdog` go to the closed loop (its watchdog's clock, and its trip/recovery callback).
    Raises UnknownNameError for an unregistered name and ConfigError for configs that do not work together.
    """
    controller = make_controller(
        task_name,
        optimizer_name,
        controller_config=controller_config,
        optimizer_config=optimizer_config,
        num_workers=num_workers,
        seed=seed,
        backend=backend,
    )
    if task_config is not None:
        controller.task.config = task_config
    if system is None:
        system = MujocoSystem.from_task(controller.task, seed)
    closed_loop = ClosedLoop(controller, system, clock=clock, on_watchdog=on_watchdog)
    return Session(task_name, optimizer_name, controller, system, closed_loop, generation)
