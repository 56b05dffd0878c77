"""Name -> class registries for tasks, optimizers and estimators, per-task config overrides, and
make_controller."""

from collections.abc import Callable, Collection
from typing import Any, Literal, cast

import numpy as np

from judo.core.configuration.config import (
    Config,
    ConfigT,
    check_seed,
    coerce_field_value,
    with_updates,
)
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import ModelOverrides, override_task_models
from judo.core.controller import Controller
from judo.core.errors import JudoError, UnknownNameError
from judo.core.estimator import Estimator, EstimatorConfig
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.core.policies.proposals import check_policy_fits
from judo.core.policy import Policy
from judo.core.rollouts.backend import RolloutBackend
from judo.core.task import Task, TaskConfig, new_task

ConfigKind = Literal["controller", "optimizer", "task"]
"""The three configs of a running pair: the controller's, the optimizer's and the task's."""
CONFIG_KINDS: tuple[ConfigKind, ...] = ("controller", "optimizer", "task")
CONFIG_GROUPS = {
    "controller": "controller",
    "optimizer": "optimizer_config",
    "task": "task_config",
    "estimator": "estimator_config",
}
"""Config kind -> the option group holding its fields (`--controller.horizon`,
`--optimizer-config.sigma`, ...)."""


def config_flag(kind: str, field_name: str) -> str:
    """The command-line option that sets field `field_name` of the `kind` config (a key of
    CONFIG_GROUPS): ("controller", "max_plan_age") -> "--controller.max-plan-age"."""
    return f"--{CONFIG_GROUPS[kind]}.{field_name}".replace("_", "-")


_TASKS: dict[str, tuple[type[Task], type[TaskConfig]]] = {}
_OPTIMIZERS: dict[str, tuple[type[Optimizer], type[OptimizerConfig]]] = {}
_ESTIMATORS: dict[str, tuple[type[Estimator], type[EstimatorConfig]]] = {}
_OVERRIDES: dict[tuple[Any, ...], dict[str, Any]] = {}
"""(task, config class) -> overrides for every optimizer; (task, config class, optimizer) -> that
optimizer's."""
_MODEL_OVERRIDES: dict[tuple[str, bool], ModelOverrides] = {}
"""(task, plant?) -> {field: {element: value}} for the planning model (False) or the simulated plant
(True)."""
_FITTED: dict[str, set[str]] = {}
"""task -> the "FIELD.ELEMENT" entries of its planning-model overrides that sysid fitted (its file's
[sysid.TASK])."""


def _check_class(what: str, cls: Any, base: type) -> None:
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise JudoError(f"{what} must be a subclass of {base.__name__}, got {cls!r}")


def register_task(name: str, task_cls: type[Task], config_cls: type[TaskConfig]) -> None:
    """Make `task_cls` (constructible with no arguments) selectable as `name`; replaces an earlier
    entry."""
    _check_class(f"task {name!r}", task_cls, Task)
    _check_class(f"config of task {name!r}", config_cls, TaskConfig)
    _TASKS[name] = (task_cls, config_cls)


def register_optimizer(
    name: str, optimizer_cls: type[Optimizer], config_cls: type[OptimizerConfig]
) -> None:
    """Make `optimizer_cls` selectable as `name`; replaces an earlier entry."""
    _check_class(f"optimizer {name!r}", optimizer_cls, Optimizer)
    _check_class(f"config of optimizer {name!r}", config_cls, OptimizerConfig)
    _OPTIMIZERS[name] = (optimizer_cls, config_cls)


def register_estimator(
    name: str, estimator_cls: type[Estimator], config_cls: type[EstimatorConfig]
) -> None:
    """Make `estimator_cls` (constructible as cls(task, config)) selectable as `name`; replaces an
    earlier entry."""
    _check_class(f"estimator {name!r}", estimator_cls, Estimator)
    _check_class(f"config of estimator {name!r}", config_cls, EstimatorConfig)
    _ESTIMATORS[name] = (estimator_cls, config_cls)


def get_registered_estimators() -> dict[str, tuple[type[Estimator], type[EstimatorConfig]]]:
    """name -> (estimator class, config class), a copy."""
    return dict(_ESTIMATORS)


def lookup_estimator(name: str) -> tuple[type[Estimator], type[EstimatorConfig]]:
    """The registered (estimator class, config class) for `name`; UnknownNameError lists the valid
    names."""
    if name not in _ESTIMATORS:
        raise UnknownNameError("estimator", name, _ESTIMATORS)
    return _ESTIMATORS[name]


def make_estimator(
    name: str, task: Task, config: EstimatorConfig | None = None, task_name: str | None = None
) -> Estimator:
    """The registered estimator `name` on `task`'s planning model, with `config` or the registered
    defaults (with `task_name`'s overrides, e.g. an [ekf] table in the task's TOML)."""
    estimator_cls, config_cls = lookup_estimator(name)
    if config is None:
        config = make_config(config_cls, task_name) if task_name else config_cls()
    return estimator_cls(task, config)


def get_registered_tasks() -> dict[str, tuple[type[Task], type[TaskConfig]]]:
    """name -> (task class, config class), a copy."""
    return dict(_TASKS)


def get_registered_optimizers() -> dict[str, tuple[type[Optimizer], type[OptimizerConfig]]]:
    """name -> (optimizer class, config class), a copy."""
    return dict(_OPTIMIZERS)


def lookup_task(name: str) -> tuple[type[Task], type[TaskConfig]]:
    """The registered (task class, config class) for `name`; UnknownNameError lists the valid
    names."""
    if name not in _TASKS:
        raise UnknownNameError("task", name, _TASKS)
    return _TASKS[name]


def make_task(name: str) -> Task:
    """A new instance of the task registered as `name`, with its registered model and plant
    overrides (`set_model_overrides`) in force; UnknownNameError lists the valid names."""
    # register_task takes classes built with no arguments
    task_cls = cast(Callable[[], Task], lookup_task(name)[0])
    return with_model_overrides(task_cls(), name)


def set_model_overrides(
    task_name: str, overrides: ModelOverrides, *, plant: bool = False, fitted: Collection[str] = ()
) -> None:
    """Set MjModel fields by element name whenever `task_name` is built: `overrides` is {field:
    {element: value}}, e.g. {"body_mass": {"pole": 0.13}} (judo.core.configuration.model_overrides).
    They go to the planning model, or with `plant` to the simulated plant only
    ([model_overrides.TASK] and [plant_overrides.TASK] in a config file); `fitted` names the
    "FIELD.ELEMENT" entries sysid fitted (`fitted_overrides`). Later calls merge into earlier ones.
    Names, shapes and values are checked now, with the earlier ones, against the task's model:
    UnknownNameError lists the valid fields or elements, ConfigError names the shape expected or
    what MuJoCo cannot simulate."""
    task = new_task(lookup_task(task_name)[0])
    model = task.sim_model if plant else task.model
    merged = {
        field: dict(values)
        for field, values in _MODEL_OVERRIDES.get((task_name, plant), {}).items()
    }
    for field, values in check_model_overrides(model, overrides, simulable=False).items():
        merged.setdefault(field, {}).update(values)
    # what they make together, as every task built from now on has it
    check_model_overrides(model, merged)
    _MODEL_OVERRIDES[(task_name, plant)] = merged
    if not plant:
        entries = {
            f"{field}.{element}" for field, values in overrides.items() for element in values
        }
        _FITTED[task_name] = (_FITTED.get(task_name, set()) - entries) | (entries & set(fitted))


def fitted_overrides(task_name: str) -> frozenset[str]:
    """The "FIELD.ELEMENT" entries of `task_name`'s planning-model overrides that sysid fitted:
    those its --out file lists under [sysid.TASK] fitted (a later override of the same entry by hand
    is not fitted)."""
    return frozenset(_FITTED.get(task_name, ()))


def model_overrides(task_name: str, *, plant: bool = False) -> ModelOverrides:
    """The model (or with `plant`, plant) overrides registered for `task_name`, {} where none
    are."""
    return {
        field: dict(values)
        for field, values in _MODEL_OVERRIDES.get((task_name, plant), {}).items()
    }


def with_model_overrides(task: Task, task_name: str) -> Task:
    """`task` with the overrides registered for `task_name`: its planning model replaced by an
    overridden copy (`task.model_overrides`), and its plant model too where plant overrides are
    registered (`task.plant_overrides`, which `MujocoSystem.from_task` gives every plant built from
    it)."""
    return override_task_models(
        task, model_overrides(task_name), model_overrides(task_name, plant=True)
    )


def lookup_optimizer(name: str) -> tuple[type[Optimizer], type[OptimizerConfig]]:
    """The registered (optimizer class, config class) for `name`; UnknownNameError lists the valid
    names."""
    if name not in _OPTIMIZERS:
        raise UnknownNameError("optimizer", name, _OPTIMIZERS)
    return _OPTIMIZERS[name]


def set_config_overrides(
    task_name: str,
    config_cls: type[Config],
    overrides: dict[str, Any],
    optimizer_name: str | None = None,
) -> None:
    """Use `overrides` ({field: value}) as the defaults of `config_cls` whenever `task_name` is
    active (and, with `optimizer_name`, only with that optimizer, applied after the task-wide
    overrides: how [controller_config_overrides.<task>.<optimizer>] gives one optimizer its own
    horizon).

    Overrides on a base class (e.g. OptimizerConfig) apply to all its subclasses; later calls merge
    into earlier ones. Field names and values are checked now, so a typo fails here, not mid-run.
    """
    key = (
        (task_name, config_cls)
        if optimizer_name is None
        else (task_name, config_cls, optimizer_name)
    )
    merged = {**_OVERRIDES.get(key, {}), **overrides}
    probe = config_cls()
    checked = {name: coerce_field_value(probe, name, value) for name, value in merged.items()}
    task_wide = _OVERRIDES.get((task_name, config_cls), {}) if optimizer_name is not None else {}
    # range checks, and cross-field checks on a concrete class
    with_updates(probe, {**task_wide, **checked})
    _OVERRIDES[key] = checked


def make_config(
    config_cls: type[ConfigT], task_name: str, optimizer_name: str | None = None
) -> ConfigT:
    """A new `config_cls` with the overrides registered for `task_name`, base classes' first, then
    (given `optimizer_name`) those registered for that optimizer alone, base classes' first."""
    updates: dict[str, Any] = {}
    for cls in reversed(config_cls.__mro__):
        updates.update(_OVERRIDES.get((task_name, cls), {}))
    if optimizer_name is not None:
        for cls in reversed(config_cls.__mro__):
            updates.update(_OVERRIDES.get((task_name, cls, optimizer_name), {}))
    return with_updates(config_cls(), updates)


def default_configs(task_name: str, optimizer_name: str) -> dict[ConfigKind, Config]:
    """The controller, optimizer and task configs of the pair with the task's registered overrides,
    by kind. Raises UnknownNameError for an unregistered name."""
    return {
        "controller": make_config(ControllerConfig, task_name, optimizer_name),
        "optimizer": make_config(lookup_optimizer(optimizer_name)[1], task_name),
        "task": make_config(lookup_task(task_name)[1], task_name),
    }


def make_controller(
    task_name: str,
    optimizer_name: str,
    *,
    controller_config: ControllerConfig | None = None,
    optimizer_config: OptimizerConfig | None = None,
    num_workers: int | None = None,
    seed: int | None = None,
    backend: str | RolloutBackend = "cpu",
    proposal_policy: Policy | None = None,
) -> Controller:
    """A Controller for the registered task and optimizer, with that task's overrides applied.

    Configs passed in are used as they are. `seed` seeds the optimizer's and the task's generators
    (ConfigError unless it is an integer from 0 to 2**63 - 1). `backend` names the rollout backend
    ("cpu" threads or "warp" for MuJoCo Warp; see ROLLOUT_BACKENDS), or is one already built.
    `proposal_policy` makes the candidates that `controller_config.policy_samples` asks for
    (judo.core.policies.proposals).
    """
    check_seed(seed)
    task_cls, task_config_cls = lookup_task(task_name)
    optimizer_cls, optimizer_config_cls = lookup_optimizer(optimizer_name)
    task = with_model_overrides(new_task(task_cls), task_name)
    task.config = make_config(task_config_cls, task_name)
    controller_config = controller_config or make_config(
        ControllerConfig, task_name, optimizer_name
    )
    optimizer_config = optimizer_config or make_config(optimizer_config_cls, task_name)
    optimizer = optimizer_cls(optimizer_config, task.command_size)
    if proposal_policy is not None:
        # names the task, which the Controller cannot
        check_policy_fits(task, proposal_policy, task_name)
    if seed is not None:
        optimizer.rng = np.random.default_rng(seed)
        task.rng = np.random.default_rng(seed + 1)
    return Controller(controller_config, task, optimizer, num_workers, backend, proposal_policy)
