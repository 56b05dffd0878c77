"""The app's plant named on the command line: judo's simulator, the ROS 2 bridge, or a user's System class.

    python -m judo --task cartpole --system ros2 --headless          # the ROS 2 bridge (judo.ros2.bridge)
    python -m judo --task cartpole --system my_robot:MyRobot         # a user's System subclass
    python -m judo --task cartpole --system sim                      # judo's simulator (the default)

A class is found by its "module:Class" path, loaded by name, and built with `Class.from_options(task, options)`
where it has that classmethod (the bridge does), else `Class(task)`: the task instance is the System's own. An
abstract class, or one whose constructor cannot take the task, is refused in one line before it is built.
"""

import importlib
import inspect
import typing
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Literal, cast

from judo.core.configuration.registry import lookup_task
from judo.core.errors import ConfigError, JudoError
from judo.core.task import Task, TaskConfig, new_task
from judo.loop.system import System

BUILT_IN_SYSTEMS = {"ros2": "judo.ros2.bridge:Ros2System", "unitree": "judo.unitree.bridge:UnitreeSystem"}
"""--system names judo knows -> the "module:Class" they load (by name, so the app never imports an extra)."""
SIM = "sim"
"""--system's name for judo's own simulator, the default."""


@dataclass
class Ros2Options:
    """How the ROS 2 bridge (`--system ros2`) reaches the robot: its DDS domain, topics and rate."""

    domain_id: int | None = None
    """DDS domain, 0..232; None: the ROS_DOMAIN_ID environment variable, else 0."""
    joint_states: str = "/joint_states"
    """Topic of the robot's sensor_msgs/JointState (best effort, keep last 1)."""
    odom: str = "/odom"
    """Topic of the robot's nav_msgs/Odometry, read for a task with a free joint (its base)."""
    imu: str = "/imu"
    """Topic of the robot's sensor_msgs/Imu, passed to the task in the reading's metadata["imu"]."""
    mocap: str = "/judo/mocap"
    """Topic of the robot side's geometry_msgs/PoseArray of the model's mocap bodies (a goal, a target), in the
    model's mocap order, read for a task that has them; the planner gets them as in-process, in the reading's
    metadata["mocap_pos"] and ["mocap_quat"]."""
    commands: str = "/judo/commands"
    """Topic judo writes std_msgs/Float64MultiArray commands to, in actuator order (reliable)."""
    rate_hz: float = 100.0
    """Commands written per second; step() paces the loop to it in wall time."""
    joint_map: tuple[str, ...] = ()
    """MJCF joint name = the robot's JointState name, for each joint whose names differ (e.g. slider=cart_joint)."""
    wait_s: float = 5.0
    """Seconds to wait at start for the robot's first valid JointState."""


@dataclass
class UnitreeOptions:
    """How the Unitree bridge (`--system unitree`) reaches the robot: rt/lowstate in, rt/lowcmd out."""

    robot: Literal["go2", "g1"] = "go2"
    """go2 (unitree_go messages, 12 motors) or g1 (unitree_hg messages, 29 motors)."""
    domain: int = 0
    """DDS domain, 0..232: Unitree's robots use 0."""
    interface: str | None = None
    """Network interface DDS uses (the one wired to the robot, e.g. eth0; lo for a robot process on this machine);
    None: Cyclone DDS's default choice."""
    rate_hz: float = 500.0
    """LowCmd_ messages written per second (the robot runs its PD between them); step() paces the loop to it."""
    soft_start_s: float = 2.0
    """Seconds over which gains and targets ramp in from the robot's pose at the first command, and again after a
    halt or a silence."""
    wait_s: float = 5.0
    """Seconds to wait at start for the robot's first valid LowState_."""
    silence_s: float = 0.1
    """Seconds without a valid LowState_ after which judo sends damping instead of the plan (and a robot process
    without a valid LowCmd_ applies it)."""


@dataclass
class SystemOptions:
    """The plant: `system` None is judo's simulator; "ros2" the ROS 2 bridge; "module:Class" a user's System."""

    system: str | None = None
    """None or sim (judo's simulator), ros2 (the ROS 2 bridge on DDS, needs pip install -e ".[ros2]"), unitree (a
    Unitree Go2 or G1 over its own DDS messages, pip install -e ".[unitree]"), or module:Class."""
    record: Path | None = None
    """With --system ros2: log what the robot sent and what judo commanded to this MCAP file (ROS 2 schemas)."""
    ros2: Ros2Options = field(default_factory=Ros2Options)
    unitree: UnitreeOptions = field(default_factory=UnitreeOptions)


def unitree_options(table: dict[str, Any], where: str) -> UnitreeOptions:
    """UnitreeOptions from a TOML table of its fields. ConfigError naming the field for an unknown name or a value
    of the wrong type."""
    valid = {f.name for f in fields(UnitreeOptions)}
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in valid:
            raise ConfigError(f"{where}: unknown field {key!r}; valid fields are: {', '.join(sorted(valid))}")
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if key == "domain" and not (isinstance(value, int) and not isinstance(value, bool)):
            raise ConfigError(f"{where}: domain must be an integer 0..232, got {value!r}")
        if key in ("rate_hz", "soft_start_s", "wait_s", "silence_s"):
            if not number:
                raise ConfigError(f"{where}: {key} must be a number, got {value!r}")
            value = float(value)
        if key in ("robot", "interface") and not isinstance(value, str):
            raise ConfigError(f"{where}: {key} must be a string, got {value!r}")
        values[key] = value
    return UnitreeOptions(**values)


def ros2_options(table: dict[str, Any], where: str) -> Ros2Options:
    """Ros2Options from a TOML table of its fields (`joint_map` a table {mjcf_name = robot_name} or a list of
    "mjcf_name=robot_name"). ConfigError naming the field for an unknown name or a value of the wrong type."""
    valid = {f.name: f for f in fields(Ros2Options)}
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in valid:
            raise ConfigError(f"{where}: unknown field {key!r}; valid fields are: {', '.join(valid)}")
        if key == "joint_map":
            if isinstance(value, dict):
                value = [f"{k}={v}" for k, v in value.items()]
            if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
                raise ConfigError(f"{where}: joint_map must be a table mjcf_name = robot_name, got {value!r}")
            value = tuple(value)
        elif key == "domain_id":
            if not (isinstance(value, int) and not isinstance(value, bool)):
                raise ConfigError(f"{where}: domain_id must be an integer 0..232, got {value!r}")
        elif key in ("rate_hz", "wait_s"):
            if not (isinstance(value, int | float) and not isinstance(value, bool)):
                raise ConfigError(f"{where}: {key} must be a number, got {value!r}")
            value = float(value)
        elif not isinstance(value, str):
            raise ConfigError(f"{where}: {key} must be a topic name (a string), got {value!r}")
        values[key] = value
    return Ros2Options(**values)


def system_class(name: str) -> type[System]:
    """The System class `name` names: "ros2" or "module:Class". Raises JudoError naming what was expected."""
    path = BUILT_IN_SYSTEMS.get(name, name)
    module_name, sep, class_name = path.partition(":")
    if not sep or not module_name or not class_name:
        valid = ", ".join(sorted([SIM, *BUILT_IN_SYSTEMS]))
        raise ConfigError(f"--system expects {valid} or module:Class (a System subclass), got {name!r}")
    try:
        module = importlib.import_module(module_name)
    except JudoError:
        raise
    except ImportError as err:
        raise ConfigError(f"--system {name}: cannot import module {module_name!r}: {err}") from err
    cls = getattr(module, class_name, None)
    if not (isinstance(cls, type) and issubclass(cls, System)):
        got = "nothing" if cls is None else type(cls).__name__ if not isinstance(cls, type) else cls.__name__
        raise ConfigError(f"--system {name}: expected a System subclass {class_name!r} in {module_name}, got {got}")
    if inspect.isabstract(cls):
        missing = ", ".join(sorted(cls.__abstractmethods__))
        raise ConfigError(
            f"--system {name}: expected a System subclass that writes every method, got {cls.__name__}, which leaves "
            f"{missing} abstract (judo.loop.system:MujocoSystem is judo's simulator)"
        )
    return cls


def build_system(options: SystemOptions, task_name: str, task_config: TaskConfig | None = None) -> System | None:
    """The plant `options` name for `task_name` (a new task instance, with `task_config` when given), or None
    for judo's own simulator (`system` None or "sim")."""
    if options.system is None or options.system == SIM:
        if options.record is not None:
            raise ConfigError(f"--record {options.record} logs a robot's link: give it with --system ros2")
        return None
    cls = system_class(options.system)
    task: Task = new_task(lookup_task(task_name)[0])
    if task_config is not None:
        task.config = task_config
    from_options = getattr(cls, "from_options", None)
    if callable(from_options):
        return cast(System, from_options(task, options))
    if options.record is not None:
        raise ConfigError(f"--record logs the ROS 2 bridge's link; {cls.__name__} takes no --record")
    _check_builds_with(cls, task, options.system)
    return cls(task)  # type: ignore[call-arg]


def _check_builds_with(cls: type[System], task: Task, name: str) -> None:
    """ConfigError unless `cls(task)` can be called: its constructor takes the task as its one required argument,
    of the type it annotates (e.g. DynamicsSystem's DynamicsTask)."""
    try:
        signature = inspect.signature(cls)
        bound = signature.bind(task)
    except TypeError:
        raise ConfigError(
            f"--system {name}: expected a System subclass built with Class(task) or Class.from_options(task, "
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
            f"--system {name}: {cls.__name__} needs a task that is a {wanted.__name__}, got {type(task).__name__}"
        )
