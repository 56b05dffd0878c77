"""TOML config files: register custom tasks and optimizers by import path and set per-task
overrides.

task = "my_task"                      # initial task
optimizer = "mppi"                    # initial optimizer
[custom_tasks.my_task]
task = "my_module.MyTask"             # dotted import paths; the file's folder is importable (after
                                      # installed packages), and importing runs the module's code
config = "my_module.MyTaskConfig"
[custom_optimizers.my_opt]
optimizer = "my_module.MyOpt"
config = "my_module.MyOptConfig"
[controller_config_overrides.my_task]
horizon = 1.0
[controller_config_overrides.my_task.mppi]      # only with mppi, after the task-wide section
horizon = 0.8
[optimizer_config_overrides.cylinder_push.my_opt]
param = 42
[optimizer_config_overrides.cylinder_push.all]   # "all": every optimizer (OptimizerConfig's fields)
num_rollouts = 64
[task_config_overrides.cartpole]
w_centered = 5.0
[estimator_config_overrides.cartpole.ekf]
process_noise_velocity = 0.02
system = "ros2"                       # the plant: "ros2" (the ROS 2 bridge) or "module:Class" (--system)
[ros2]                                # the bridge's settings, the fields of --ros2.* (flags win)
domain_id = 7
commands = "/forward_command_controller/commands"
joint_map = { slider = "cart_joint" } # MJCF joint name = the robot's JointState name
[model_overrides.cartpole]                      # MjModel fields of the planning model, by element name
body_mass.pole = 0.13
geom_friction.cart = [0.9, 0.005, 0.0001]
[plant_overrides.cartpole]                      # the simulated plant's only (a mismatched plant to rehearse on)
dof_damping.slider = 0.5
[sysid.cartpole]                                # written by sysid: the [model_overrides.cartpole] entries it fitted
fitted = ["body_mass.pole"]
[safety.cartpole]                               # the owner's limits (judo.safety, docs/safety.md)
position = ["slider=-1:1"]
"""  # noqa: E501

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from judo.core.configuration.config import Config, with_updates
from judo.core.configuration.config_file_text import ConfigFileError, read_config_text
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.dotted_import import import_dotted
from judo.core.configuration.registry import (
    get_registered_optimizers,
    lookup_estimator,
    lookup_optimizer,
    lookup_task,
    make_config,
    register_optimizer,
    register_task,
    set_config_overrides,
    set_model_overrides,
)
from judo.core.errors import JudoError, UnknownNameError
from judo.core.optimizer import OptimizerConfig

TOP_LEVEL_KEYS = (
    "task",
    "optimizer",
    "custom_tasks",
    "custom_optimizers",
    "controller_config_overrides",
    "optimizer_config_overrides",
    "task_config_overrides",
    "estimator_config_overrides",
    "system",
    "ros2",
    "unitree",
    "model_overrides",
    "plant_overrides",
    "sysid",
    "safety",
)

TASK_SECTIONS: dict[str, tuple[type[Config], Callable[[str, Any], None]]] = {}
"""Per-task sections whose config class lives above core ([safety.TASK], registered by
judo.builtin): section -> (the class whose task defaults the table sets, `check(task_name, config)`:
the checks against the task's model)."""


def register_task_section(
    section: str, config_cls: type[Config], check: Callable[[str, Any], None]
) -> None:
    """Let a file's [`section`.TASK] tables set `config_cls`'s defaults, each `check(task_name,
    config)`ed first."""
    TASK_SECTIONS[section] = (config_cls, check)


ALL_OPTIMIZERS = "all"
"""The optimizer name in [optimizer_config_overrides.<task>.all]: OptimizerConfig, so every
optimizer."""


@dataclass
class LoadedConfig:
    """What a config file asks for at start-up (None where it does not say)."""

    task: str | None
    optimizer: str | None
    path: Path
    system: str | None = None
    """The plant the file names (`system = "ros2"` or "module:Class")."""
    ros2: dict[str, Any] = field(default_factory=dict)
    """The [ros2] table: the ROS 2 bridge's settings by field name, checked where they are used."""
    unitree: dict[str, Any] = field(default_factory=dict)
    """The [unitree] table: the Unitree bridge's settings by field name, checked where they are
    used."""


def load_config(path: str | Path) -> LoadedConfig:
    """Read the TOML file at `path`, register its custom classes and apply its overrides.

    Raises ConfigFileError naming the file and the offending key or line; nothing is registered
    unless the whole file is valid up to the failing entry.
    """
    path = Path(path)
    text = read_config_text(path)
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        where = "" if "line" in str(err) else f" (at line {max(1, len(text.splitlines()))})"
        raise ConfigFileError(f"{path}: TOML syntax error: {err}{where}") from None
    # an integer of more digits than Python converts (sys.get_int_max_str_digits)
    except ValueError as err:
        raise ConfigFileError(f"{path}: a value could not be read: {str(err)[:200]}") from None

    unknown = sorted(set(table) - set(TOP_LEVEL_KEYS))
    if unknown:
        raise ConfigFileError(
            f"{path}: unknown top-level key {unknown[0]!r}; valid keys are: "
            f"{', '.join(TOP_LEVEL_KEYS)}"
        )
    folder = path.parent.resolve()
    # Only a file that registers classes needs its folder importable. Appended, not prepended: a
    # file beside the config (say websockets.py) must never shadow an installed package, while
    # modules the file names, and their own sibling imports, still resolve.
    registers_classes = bool(table.get("custom_tasks") or table.get("custom_optimizers"))
    if registers_classes and str(folder) not in sys.path:
        sys.path.append(str(folder))

    def fail(where: str, err: Exception) -> ConfigFileError:
        return ConfigFileError(f"{path}: [{where}]: {err}")

    for section, class_key, register in (
        ("custom_tasks", "task", register_task),
        ("custom_optimizers", "optimizer", register_optimizer),
    ):
        for name, entry in _table(table, section, path).items():
            where = f"{section}.{name}"
            try:
                classes = [
                    import_dotted(_entry(entry, key, where, path), key, folder)
                    for key in (class_key, "config")
                ]
                register(name, *classes)
            except JudoError as err:
                raise fail(where, err) from None

    for task_name, overrides in _table(table, "controller_config_overrides", path).items():
        where = f"controller_config_overrides.{task_name}"
        try:
            lookup_task(task_name)
        except UnknownNameError as err:
            raise fail(where, err) from None
        if not isinstance(overrides, dict):
            raise ConfigFileError(
                f"{path}: [{where}] must be a table of field = value, got {overrides!r}"
            )
        task_wide = {key: value for key, value in overrides.items() if not isinstance(value, dict)}
        _apply(path, where, task_name, ControllerConfig, task_wide)
        for optimizer_name, per_optimizer in overrides.items():
            if isinstance(per_optimizer, dict):
                if optimizer_name not in get_registered_optimizers():
                    err = UnknownNameError("optimizer", optimizer_name, get_registered_optimizers())
                    raise fail(f"{where}.{optimizer_name}", err)
                _apply(
                    path,
                    f"{where}.{optimizer_name}",
                    task_name,
                    ControllerConfig,
                    per_optimizer,
                    optimizer_name,
                )
    for task_name, overrides in _table(table, "task_config_overrides", path).items():
        where = f"task_config_overrides.{task_name}"
        try:
            config_cls = lookup_task(task_name)[1]
        except UnknownNameError as err:
            raise fail(where, err) from None
        _apply(path, where, task_name, config_cls, overrides)
    per_task = _table(table, "optimizer_config_overrides", path)
    for task_name in per_task:
        for optimizer_name, overrides in _table(per_task, task_name, path).items():
            where = f"optimizer_config_overrides.{task_name}.{optimizer_name}"
            try:
                lookup_task(task_name)
                config_cls = optimizer_config_class(optimizer_name)
            except UnknownNameError as err:
                raise fail(where, err) from None
            _apply(path, where, task_name, config_cls, overrides)

    per_task = _table(table, "estimator_config_overrides", path)
    for task_name in per_task:
        for estimator_name, overrides in _table(per_task, task_name, path).items():
            where = f"estimator_config_overrides.{task_name}.{estimator_name}"
            try:
                config_cls = lookup_estimator(estimator_name)[1]
            except UnknownNameError as err:
                raise fail(where, err) from None
            _apply(path, where, task_name, config_cls, overrides)

    fitted = _fitted(table, path)
    for section in ("model_overrides", "plant_overrides"):
        for task_name, overrides in _table(table, section, path).items():
            plant = section == "plant_overrides"
            try:
                lookup_task(task_name)
                set_model_overrides(
                    task_name,
                    overrides,
                    plant=plant,
                    fitted=() if plant else fitted.get(task_name, ()),
                )
            except JudoError as err:
                raise fail(f"{section}.{task_name}", err) from None

    for section, (section_config, check_section) in [
        (n, entry) for n, entry in TASK_SECTIONS.items() if n in table
    ]:
        for task_name, overrides in _table(table, section, path).items():
            where = f"{section}.{task_name}"
            try:
                lookup_task(task_name)
                if not isinstance(overrides, dict):
                    raise JudoError(f"expected a table of field = value, got {overrides!r}")
                check_section(
                    task_name, with_updates(make_config(section_config, task_name), overrides)
                )
            except JudoError as err:
                raise fail(where, err) from None
            _apply(path, where, task_name, section_config, overrides)

    for key, lookup in (("task", lookup_task), ("optimizer", lookup_optimizer)):
        if key in table:
            try:
                lookup(table[key])
            except UnknownNameError as err:
                raise fail(key, err) from None
    system = table.get("system")
    if system is not None and not isinstance(system, str):
        raise ConfigFileError(
            f'{path}: system must be a string ("ros2" or "module:Class"), got {system!r}'
        )
    ros2 = table.get("ros2", {})
    if not isinstance(ros2, dict):
        raise ConfigFileError(f"{path}: [ros2] must be a table of field = value, got {ros2!r}")
    unitree = table.get("unitree", {})
    if not isinstance(unitree, dict):
        raise ConfigFileError(
            f"{path}: [unitree] must be a table of field = value, got {unitree!r}"
        )
    return LoadedConfig(table.get("task"), table.get("optimizer"), path, system, ros2, unitree)


def optimizer_config_class(name: str) -> type[OptimizerConfig]:
    """The config class that [optimizer_config_overrides.<task>.<name>] sets: OptimizerConfig for
    "all"."""
    if name == ALL_OPTIMIZERS:
        return OptimizerConfig
    if name not in get_registered_optimizers():
        raise UnknownNameError("optimizer", name, [*get_registered_optimizers(), ALL_OPTIMIZERS])
    return lookup_optimizer(name)[1]


def _fitted(table: dict[str, Any], path: Path) -> dict[str, list[str]]:
    """task -> the entries of its [model_overrides.TASK] that sysid fitted: [sysid.TASK] fitted =
    ["FIELD.ELEMENT", ...], which sysid writes in its --out file; ConfigFileError for another form
    or an entry the file does not set."""
    fitted = {}
    for task_name, entry in _table(table, "sysid", path).items():
        where = f"{path}: [sysid.{task_name}]"
        if not isinstance(entry, dict) or set(entry) != {"fitted"}:
            raise ConfigFileError(
                f'{where} must hold only fitted = ["FIELD.ELEMENT", ...], got {entry!r}'
            )
        names = entry["fitted"]
        if not (isinstance(names, list) and all(isinstance(name, str) for name in names)):
            raise ConfigFileError(
                f'{where}: fitted must be a list of "FIELD.ELEMENT" strings, got {names!r}'
            )
        sections = table.get("model_overrides")
        overrides = sections.get(task_name) if isinstance(sections, dict) else None
        overrides = overrides if isinstance(overrides, dict) else {}
        entries = [
            f"{f}.{e}"
            for f, values in overrides.items()
            if isinstance(values, dict)
            for e in values
        ]
        for name in names:
            if name not in entries:
                raise ConfigFileError(
                    f"{where}: fitted names {name!r}, which [model_overrides.{task_name}] "
                    "does not set; "
                    f"it sets: {', '.join(entries) or 'nothing'}"
                )
        fitted[task_name] = names
    return fitted


def _table(table: dict[str, Any], key: str, path: Path) -> dict[str, Any]:
    value = table.get(key, {})
    if not isinstance(value, dict):
        raise ConfigFileError(f"{path}: [{key}] must be a table, got {value!r}")
    return value


def _entry(entry: Any, key: str, where: str, path: Path) -> str:
    if not isinstance(entry, dict) or not isinstance(entry.get(key), str):
        raise ConfigFileError(f'{path}: [{where}] needs {key} = "module.ClassName"')
    return entry[key]


def _apply(
    path: Path,
    where: str,
    task_name: str,
    config_cls: type,
    overrides: Any,
    optimizer_name: str | None = None,
) -> None:
    if not isinstance(overrides, dict):
        raise ConfigFileError(
            f"{path}: [{where}] must be a table of field = value, got {overrides!r}"
        )
    try:
        set_config_overrides(task_name, config_cls, overrides, optimizer_name)
    except JudoError as err:
        raise ConfigFileError(f"{path}: [{where}]: {err}") from None
