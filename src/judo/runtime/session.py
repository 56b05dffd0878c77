"""What the app runs at one moment: a task and optimizer by name, their Controller, and the plant it drives.

Switching task or optimizer builds a new Session and closes the old one; nothing is patched in place.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.controller import Controller, ControllerConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import lookup_optimizer, lookup_task, make_config, make_controller
from judo.core.task import Task, TaskConfig
from judo.runtime.system import MujocoSystem, System


@dataclass
class Session:
    """A controller and its plant.

    Attributes:
        task_name, optimizer_name: registry names.
        controller: plans on its own Task instance (`controller.task`).
        system: the plant; a MujocoSystem on `plant_task`, or the user's own System (hardware).
        plant_task: the Task instance the simulator steps (its `data` is the plant), or None for a
            user System.
        generation: counts sessions within one app, so stale GUI edits and snapshots are recognised.
    """

    task_name: str
    optimizer_name: str
    controller: Controller
    system: System
    plant_task: Task | None
    generation: int

    def close(self) -> None:
        """Stop the controller's rollout threads."""
        self.controller.close()


def default_configs(task_name: str, optimizer_name: str) -> dict[str, object]:
    """The controller, optimizer and task configs of `task_name` with its registered overrides, by kind."""
    _, task_config_cls = lookup_task(task_name)
    _, optimizer_config_cls = lookup_optimizer(optimizer_name)
    return {
        "controller": make_config(ControllerConfig, task_name, optimizer_name),
        "optimizer": make_config(optimizer_config_cls, task_name),
        "task": make_config(task_config_cls, task_name),
    }


def build_session(
    task_name: str,
    optimizer_name: str,
    generation: int,
    *,
    controller_config: ControllerConfig | None = None,
    optimizer_config: OptimizerConfig | None = None,
    task_config: TaskConfig | None = None,
    system: System | None = None,
    plant_task: Task | None = None,
    seed: int | None = None,
    num_workers: int | None = None,
    backend: str = "cpu",
) -> Session:
    """A new Session. Configs left out get the task's registered defaults.

    With no `system`, the plant is a MujocoSystem on a second instance of the task class, sharing
    the controller task's config and reset to its start state. A given `system` (with the
    `plant_task` it steps, if any) is kept as it is, e.g. the user's hardware or the running plant
    when only the optimizer changes. `backend` names the controller's rollout backend. Raises
    UnknownNameError for an unregistered name and ConfigError for configs that do not work together.
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
        task_cls: Any = type(controller.task)  # registered tasks construct with no arguments
        simulated: Task = task_cls()
        simulated.config = controller.task.config
        simulated.rng = np.random.default_rng(None if seed is None else seed + 2)
        simulated.reset()
        system, plant_task = MujocoSystem(simulated), simulated
    return Session(task_name, optimizer_name, controller, system, plant_task, generation)
