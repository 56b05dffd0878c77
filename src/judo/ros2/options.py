"""How judo's two DDS bridges reach the robot: `Ros2Options` (`--system ros2`, judo.ros2.bridge) and
`UnitreeOptions` (`--system unitree`, judo.unitree.bridge), each from the command line (`--ros2.*`,
`--unitree.*`) or a TOML table of its fields (`ros2_options`, `unitree_options`: the config file's
[ros2] and [unitree]).

Both live here, below judo.unitree: the Unitree bridge builds on judo.ros2's link, and the ROS 2
fake robot (judo.ros2.plant) serves either protocol.
"""

from dataclasses import dataclass, fields
from typing import Any, Literal

from judo.core.errors import ConfigError


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
    """Topic of the robot side's geometry_msgs/PoseArray of the model's mocap bodies (a goal, a
    target), in the model's mocap order, read for a task that has them; the planner gets them as
    in-process, in the reading's metadata["mocap_pos"] and ["mocap_quat"]."""
    commands: str = "/judo/commands"
    """Topic judo writes std_msgs/Float64MultiArray commands to, in actuator order (reliable)."""
    rate_hz: float = 100.0
    """Commands written per second; step() paces the loop to it in wall time."""
    joint_map: tuple[str, ...] = ()
    """MJCF joint name = the robot's JointState name, for each joint whose names differ (e.g.
    slider=cart_joint)."""
    wait_s: float = 5.0
    """Seconds to wait at start for the robot's first valid JointState."""


@dataclass
class UnitreeOptions:
    """How the Unitree bridge (`--system unitree`) reaches the robot: rt/lowstate in, rt/lowcmd
    out."""

    robot: Literal["go2", "g1"] = "go2"
    """go2 (unitree_go messages, 12 motors) or g1 (unitree_hg messages, 29 motors)."""
    domain: int = 0
    """DDS domain, 0..232: Unitree's robots use 0."""
    interface: str | None = None
    """Network interface DDS uses (the one wired to the robot, e.g. eth0; lo for a robot process on
    this machine); None: Cyclone DDS's default choice."""
    rate_hz: float = 500.0
    """LowCmd_ messages written per second (the robot runs its PD between them); step() paces the
    loop to it."""
    soft_start_s: float = 2.0
    """Seconds over which gains and targets ramp in from the robot's pose at the first command, and
    again after a halt or a silence."""
    wait_s: float = 5.0
    """Seconds to wait at start for the robot's first valid LowState_."""
    silence_s: float = 0.1
    """Seconds without a valid LowState_ after which judo sends damping instead of the plan (and a
    robot process without a valid LowCmd_ applies it)."""


def ros2_options(table: dict[str, Any], where: str) -> Ros2Options:
    """Ros2Options from a TOML table of its fields (`joint_map` a table {mjcf_name = robot_name} or
    a list of "mjcf_name=robot_name"). ConfigError naming the field for an unknown name or a value
    of the wrong type."""
    valid = {f.name: f for f in fields(Ros2Options)}
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in valid:
            raise ConfigError(
                f"{where}: unknown field {key!r}; valid fields are: {', '.join(valid)}"
            )
        if key == "joint_map":
            if isinstance(value, dict):
                value = [f"{k}={v}" for k, v in value.items()]
            if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
                raise ConfigError(
                    f"{where}: joint_map must be a table mjcf_name = robot_name, got {value!r}"
                )
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


def unitree_options(table: dict[str, Any], where: str) -> UnitreeOptions:
    """UnitreeOptions from a TOML table of its fields. ConfigError naming the field for an unknown
    name or a value of the wrong type."""
    valid = {f.name for f in fields(UnitreeOptions)}
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in valid:
            raise ConfigError(
                f"{where}: unknown field {key!r}; valid fields are: {', '.join(sorted(valid))}"
            )
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
