"""The plant a command line names (`--system`: `SystemOptions`, `build_system`), for the app and
the commands that drive one:

    python -m judo --task cartpole --system ros2 --headless          # the ROS 2 bridge (judo.ros2.bridge)
    python -m judo --task cartpole --system my_robot:MyRobot         # a user's System subclass
    python -m judo --task cartpole --system sim                      # judo's simulator (the default)

A class is found by its "module:Class" path, loaded by name, and built
with `Class.from_options(task, options)` where it has that classmethod (the bridge does),
else `Class(task)`: the task instance is the System's own. An abstract class, or one whose
constructor cannot take the task, is refused in one line before it is built.

It sits above the bridges (judo.ros2, judo.unitree) and below the command packages and the runtime.
"""  # noqa: E501

import dataclasses
import importlib
import inspect
import typing
from collections.abc import Callable
from pathlib import Path
from typing import cast

from judo.core.configuration.registry import lookup_task
from judo.core.errors import ConfigError, JudoError
from judo.core.task import Task as JudoTask
from judo.core.task import TaskConfig, new_task
from judo.loop.system import System
from judo.ros2.options import Ros2Options, UnitreeOptions

BUILT_IN_SYSTEMS = {
    "ros2": "judo.ros2.bridge:Ros2System",
    "unitree": "judo.unitree.bridge:UnitreeSystem",
}
"""--system names judo knows -> the "module:Class" they load (by name, so the app never imports an
extra)."""
SIM = "sim"
"""--system's name for judo's own simulator, the default."""


@dataclasses.dataclass
class SystemOptions:
    """The plant: `system` None is judo's simulator; "ros2" the ROS 2 bridge; "module:Class" a
    user's System."""

    system: str | None = None
    """None or sim (judo's simulator), ros2 (the ROS 2 bridge on DDS, needs pip install -e
    ".[ros2]"), unitree (a Unitree Go2 or G1 over its own DDS messages, pip install -e
    ".[unitree]"), or module:Class."""
    record: Path | None = None
    """With --system ros2: log what the robot sent and what judo commanded to this MCAP file (ROS 2
    schemas)."""
    ros2: Ros2Options = dataclasses.field(default_factory=Ros2Options)
    unitree: UnitreeOptions = dataclasses.field(default_factory=UnitreeOptions)


def system_class(name: str) -> type[System]:
    """The System class `name` names: "ros2" or "module:Class". Raises JudoError naming what was
    expected."""
    path = BUILT_IN_SYSTEMS.get(name, name)
    module_name, sep, class_name = path.partition(":")
    if not sep or not module_name or not class_name:
        valid = ", ".join(sorted([SIM, *BUILT_IN_SYSTEMS]))
        raise ConfigError(
            f"--system expects {valid} or module:Class (a System subclass), got {name!r}"
        )
    try:
        module = importlib.import_module(module_name)
    except JudoError:
        raise
    except ImportError as err:
        raise ConfigError(f"--system {name}: cannot import module {module_name!r}: {err}") from err
    cls = getattr(module, class_name, None)
    if not (isinstance(cls, type) and issubclass(cls, System)):
        got = (
            "nothing"
            if cls is None
            else type(cls).__name__
            if not isinstance(cls, type)
            else cls.__name__
        )
        raise ConfigError(
            f"--system {name}: expected a System subclass {class_name!r} in {module_name}, got "
            f"{got}"
        )
    if inspect.isabstract(cls):
        missing = ", ".join(sorted(cls.__abstractmethods__))
        raise ConfigError(
            f"--system {name}: expected a System subclass that writes every method, got "
            f"{cls.__name__}, which leaves "
            f"{missing} abstract (judo.loop.system:MujocoSystem is judo's simulator)"
        )
    return cls


def build_system(
    options: SystemOptions, task_name: str, task_config: TaskConfig | None = None
) -> System | None:
    """The plant `options` name for `task_name` (a new task instance, with `task_config` when
    given), or None for judo's own simulator (`system` None or "sim")."""
    if options.system is None or options.system == SIM:
        if options.record is not None:
            raise ConfigError(
                f"--record {options.record} logs a robot's link: give it with --system ros2"
            )
        return None
    cls = system_class(options.system)
    task: JudoTask = new_task(lookup_task(task_name)[0])
    if task_config is not None:
        task.config = task_config
    from_options = getattr(cls, "from_options", None)
    if callable(from_options):
        return cast(System, from_options(task, options))
    if options.record is not None:
        raise ConfigError(
            f"--record logs the ROS 2 bridge's link; {cls.__name__} takes no --record"
        )
    _check_builds_with(cls, task, options.system)
    try:
        # a System built from the task alone (checked above)
        return cast(Callable[[JudoTask], System], cls)(task)
    # the class refused the task (DynamicsSystem a task without its own dynamics)
    except ConfigError as err:
        raise ConfigError(f"--system {options.system}: {err}") from None


def _check_builds_with(cls: type[System], task: JudoTask, name: str) -> None:
    """ConfigError unless `cls(task)` can be called: its constructor takes the task as its one
    required argument, of the type it annotates."""
    try:
        signature = inspect.signature(cls)
        bound = signature.bind(task)
    except TypeError:
        raise ConfigError(
            f"--system {name}: expected a System subclass built with Class(task) or "
            "Class.from_options(task, "
            f"options), got {cls.__name__}{signature}"
        ) from None
    except ValueError:  # a constructor without a signature Python can read: tried as it is
        return
    try:
        hints = typing.get_type_hints(cls.__init__)
    except Exception:  # an annotation that does not resolve: not checked
        return
    wanted = hints.get(next(iter(bound.arguments)))
    if isinstance(wanted, type) and not isinstance(task, wanted):
        raise ConfigError(
            f"--system {name}: {cls.__name__} needs a task that is a {wanted.__name__}, got "
            f"{type(task).__name__}"
        )
