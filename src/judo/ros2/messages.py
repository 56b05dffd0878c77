# pyright: reportCallIssue=false, reportGeneralTypeIssues=false, reportAssignmentType=false
# (cyclonedds' IDL dataclasses take `typename=` in the class line, sizes in `array[float64, 9]` and
# lists for
# `sequence` fields, which its type hints do not describe)
"""ROS 2's standard messages as DDS types, without a ROS install: the CDR on the wire is ROS 2's
own.

ROS 2 maps `sensor_msgs/msg/JointState` to the DDS type `sensor_msgs::msg::dds_::JointState_` and
the topic `/joint_states` to `rt/joint_states`; the domain is `ROS_DOMAIN_ID`. The classes here are
those types, written with `cyclonedds`' IDL dataclasses (its wheel carries the C library), and
`MSGDEFS` holds each message's ROS 2 definition text, the schema an MCAP log stores beside the
bytes.
"""

from dataclasses import dataclass, field

from judo.core.errors import import_extra

import_extra("cyclonedds", "the ROS 2 bridge", "ros2")

import cyclonedds.idl.annotations as annotate  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import array, float64, int32, sequence, uint32  # noqa: E402


@dataclass
@annotate.final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
@annotate.final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
@annotate.final
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
@annotate.final
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@annotate.final
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@annotate.final
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
@annotate.final
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
@annotate.final
class PoseArray(IdlStruct, typename="geometry_msgs::msg::dds_::PoseArray_"):
    header: Header = field(default_factory=Header)
    poses: sequence[Pose] = field(default_factory=list)


@dataclass
@annotate.final
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@annotate.final
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
@annotate.final
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@annotate.final
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
@annotate.final
class Imu(IdlStruct, typename="sensor_msgs::msg::dds_::Imu_"):
    header: Header = field(default_factory=Header)
    orientation: Quaternion = field(default_factory=Quaternion)
    orientation_covariance: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    angular_velocity: Vector3 = field(default_factory=Vector3)
    angular_velocity_covariance: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    linear_acceleration: Vector3 = field(default_factory=Vector3)
    linear_acceleration_covariance: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)


@dataclass
@annotate.final
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
@annotate.final
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
@annotate.final
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


@dataclass
@annotate.final
class Bool(IdlStruct, typename="std_msgs::msg::dds_::Bool_"):
    data: bool = False


@dataclass
@annotate.final
class LimitHit(IdlStruct, typename="judo_msgs::msg::dds_::LimitHit_"):
    """One [safety] limit acting on one served command (`judo.safety.serve_filter.LimitHit`), as the
    MCAP logs it."""

    stamp: Time = field(default_factory=Time)
    limit: str = ""
    value: float64 = 0.0


def ros_topic(name: str) -> str:
    """The DDS topic of the ROS 2 topic `name`: "/joint_states" -> "rt/joint_states"."""
    return "rt/" + name.lstrip("/")


def stamp_of(seconds: float) -> Time:
    """A ROS 2 Time of `seconds` (>= 0), to the nearest nanosecond: rounded first, then split, so a
    sum of steps a hair below a whole second is that second, 0 ns."""
    sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
    return Time(sec, nanosec)


def seconds_of(stamp: Time) -> float:
    """The seconds a ROS 2 Time stands for."""
    return stamp.sec + 1e-9 * stamp.nanosec


_TIME = "int32 sec\nuint32 nanosec"
_HEADER = "builtin_interfaces/Time stamp\nstring frame_id"
_VECTOR = "float64 x\nfloat64 y\nfloat64 z"
_QUATERNION = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1"


def _msgdef(main: str, *deps: tuple[str, str]) -> str:
    """ROS 2's concatenated definition text (the "ros2msg" schema): the message, then each
    dependency."""
    sep = "=" * 80
    return main + "".join(f"\n{sep}\nMSG: {name}\n{text}" for name, text in deps)


_HEADER_DEPS = (("std_msgs/Header", _HEADER), ("builtin_interfaces/Time", _TIME))

MSGDEFS = {
    "sensor_msgs/msg/JointState": _msgdef(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] "
        "velocity\nfloat64[] effort",
        *_HEADER_DEPS,
    ),
    "nav_msgs/msg/Odometry": _msgdef(
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
        "geometry_msgs/TwistWithCovariance twist",
        *_HEADER_DEPS,
        ("geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose pose\nfloat64[36] covariance"),
        (
            "geometry_msgs/Pose",
            "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
        ),
        ("geometry_msgs/Point", _VECTOR),
        ("geometry_msgs/Quaternion", _QUATERNION),
        ("geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist twist\nfloat64[36] covariance"),
        ("geometry_msgs/Twist", "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular"),
        ("geometry_msgs/Vector3", _VECTOR),
    ),
    "sensor_msgs/msg/Imu": _msgdef(
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] "
        "orientation_covariance\n"
        "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
        "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance",
        *_HEADER_DEPS,
        ("geometry_msgs/Quaternion", _QUATERNION),
        ("geometry_msgs/Vector3", _VECTOR),
    ),
    "geometry_msgs/msg/PoseArray": _msgdef(
        "std_msgs/Header header\ngeometry_msgs/Pose[] poses",
        *_HEADER_DEPS,
        (
            "geometry_msgs/Pose",
            "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
        ),
        ("geometry_msgs/Point", _VECTOR),
        ("geometry_msgs/Quaternion", _QUATERNION),
    ),
    "std_msgs/msg/Float64MultiArray": _msgdef(
        "std_msgs/MultiArrayLayout layout\nfloat64[] data",
        ("std_msgs/MultiArrayLayout", "std_msgs/MultiArrayDimension[] dim\nuint32 data_offset"),
        ("std_msgs/MultiArrayDimension", "string label\nuint32 size\nuint32 stride"),
    ),
    "std_msgs/msg/Bool": "bool data",
    "judo_msgs/msg/LimitHit": _msgdef(
        "builtin_interfaces/Time stamp\nstring limit\nfloat64 value",
        ("builtin_interfaces/Time", _TIME),
    ),
}
"""ROS 2 message name -> its definition text with its dependencies (MCAP's "ros2msg" schema
encoding)."""

ROS_NAMES = {
    JointState: "sensor_msgs/msg/JointState",
    Odometry: "nav_msgs/msg/Odometry",
    Imu: "sensor_msgs/msg/Imu",
}
ROS_NAMES[Float64MultiArray] = "std_msgs/msg/Float64MultiArray"
ROS_NAMES[PoseArray] = "geometry_msgs/msg/PoseArray"
ROS_NAMES[Bool] = "std_msgs/msg/Bool"
ROS_NAMES[LimitHit] = "judo_msgs/msg/LimitHit"
"""Message class -> its ROS 2 name."""
