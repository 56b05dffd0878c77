# pyright: reportArgumentType=false
# (cyclonedds types a message's list fields as its IDL `sequence`, which is a plain list at run
# time)
"""What both ends of a ROS 2 link share: the DDS domain and QoS, and a MuJoCo model's state as ROS 2
messages (`JointLayout` and `base_from_odometry`, which need no DDS, live in judo.ros2.joints).

QoS, as ROS 2 sets it: sensor streams are best effort, keep last 1 (the sensor-data profile);
commands are reliable, keep last 1 (a command is never replaced by an older one on the way).
"""

import os

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError, import_extra
from judo.ros2 import messages as msg
from judo.ros2.joints import JointLayout

dds = import_extra("cyclonedds.domain", "the ROS 2 bridge", "ros2")
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

MAX_DOMAIN_ID = 232
"""Largest DDS domain id ROS 2 allows."""
SENSOR_QOS = Qos(
    Policy.Reliability.BestEffort, Policy.History.KeepLast(1), Policy.Durability.Volatile
)
"""ROS 2's sensor-data profile."""
COMMAND_QOS = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.History.KeepLast(1),
    Policy.Durability.Volatile,
)
"""Reliable, keep last 1: what judo writes commands with."""
APPLIED_QOS = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.History.KeepLast(256),
    Policy.Durability.Volatile,
)
"""Reliable, keep last 256: the plant's record of the commands it applied (`applied`), each one kept
for the log."""


def domain_id(given: int | None) -> int:
    """The DDS domain: `given`, else $ROS_DOMAIN_ID, else 0. ConfigError outside 0..232."""
    if given is None:
        text = os.environ.get("ROS_DOMAIN_ID", "").strip()
        try:
            given = int(text) if text else 0
        except ValueError:
            raise ConfigError(
                f"ROS_DOMAIN_ID must be an integer 0..{MAX_DOMAIN_ID}, got {text!r}"
            ) from None
    if not 0 <= given <= MAX_DOMAIN_ID:
        raise ConfigError(f"the DDS domain id must be 0..{MAX_DOMAIN_ID}, got {given}")
    return given


def participant(domain: int):  # a cyclonedds DomainParticipant
    """A DDS participant on `domain`."""
    return dds.DomainParticipant(domain)


def take(reader, n: int = 16) -> list:
    """The data samples `reader` holds, up to `n`, taken; without the notices that a writer went
    away."""
    from cyclonedds.internal import InvalidSample

    return [sample for sample in reader.take(n) if not isinstance(sample, InvalidSample)]


def close_participant(participant) -> None:
    """Delete `participant` and everything it made (readers, writers, topics) now, not when it is
    collected."""
    participant.__del__()  # cyclonedds deletes an entity, with its children, in __del__ only


def topic(participant, name: str, message_type: type):
    """The DDS topic of the ROS 2 topic `name` carrying `message_type`."""
    from cyclonedds.topic import Topic

    return Topic(participant, msg.ros_topic(name), message_type)


def joint_state(
    layout: JointLayout, qpos: np.ndarray, qvel: np.ndarray, stamp: float
) -> msg.JointState:
    """The JointState of the (nq,) `qpos` and (nv,) `qvel`, stamped `stamp` seconds."""
    return msg.JointState(
        msg.Header(msg.stamp_of(stamp), ""),
        list(layout.names),
        qpos[layout.qpos].tolist(),
        qvel[layout.qvel].tolist(),
        [],
    )


def odometry(layout: JointLayout, qpos: np.ndarray, qvel: np.ndarray, stamp: float) -> msg.Odometry:
    """The base's Odometry: pose in the world ("odom") frame, twist in the body ("base_link") frame,
    as ROS 2's convention has it (MuJoCo's free joint has its linear velocity in the world
    frame)."""
    assert layout.free is not None
    a, d = layout.free
    w, x, y, z = qpos[a + 3 : a + 7]
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, qpos[a + 3 : a + 7])
    linear = rot.reshape(3, 3).T @ qvel[d : d + 3]
    pose = msg.Pose(
        msg.Point(*qpos[a : a + 3].tolist()), msg.Quaternion(float(x), float(y), float(z), float(w))
    )
    twist = msg.Twist(msg.Vector3(*linear.tolist()), msg.Vector3(*qvel[d + 3 : d + 6].tolist()))
    return msg.Odometry(
        msg.Header(msg.stamp_of(stamp), "odom"),
        "base_link",
        msg.PoseWithCovariance(pose),
        msg.TwistWithCovariance(twist),
    )


def imu(
    qpos: np.ndarray, qvel: np.ndarray, accel: np.ndarray, layout: JointLayout, stamp: float
) -> msg.Imu:
    """The base's Imu: orientation, body angular velocity and (3,) body linear acceleration
    `accel`."""
    assert layout.free is not None
    a, d = layout.free
    w, x, y, z = qpos[a + 3 : a + 7]
    return msg.Imu(
        msg.Header(msg.stamp_of(stamp), "base_link"),
        msg.Quaternion(float(x), float(y), float(z), float(w)),
        angular_velocity=msg.Vector3(*qvel[d + 3 : d + 6].tolist()),
        linear_acceleration=msg.Vector3(*np.asarray(accel, float).tolist()),
    )


def mocap_poses(mocap_pos: np.ndarray, mocap_quat: np.ndarray, stamp: float) -> msg.PoseArray:
    """The PoseArray of the model's mocap bodies, (nmocap, 3) positions and (nmocap, 4) [w x y z]
    orientations, in the world ("odom") frame."""
    poses = [
        msg.Pose(
            msg.Point(*p.tolist()),
            msg.Quaternion(float(q[1]), float(q[2]), float(q[3]), float(q[0])),
        )
        for p, q in zip(np.asarray(mocap_pos, float), np.asarray(mocap_quat, float), strict=True)
    ]
    return msg.PoseArray(msg.Header(msg.stamp_of(stamp), "odom"), poses)


def mocap_from_poses(poses: msg.PoseArray, nmocap: int) -> tuple[np.ndarray, np.ndarray]:
    """((nmocap, 3) positions, (nmocap, 4) [w x y z] unit orientations) of `poses`; JudoError for
    another count, a non-finite value or an orientation that is not a quaternion."""
    if len(poses.poses) != nmocap:
        raise JudoError(
            f"a PoseArray of {len(poses.poses)} poses; expected the model's {nmocap} mocap bodies"
        )
    pos = np.array(
        [[p.position.x, p.position.y, p.position.z] for p in poses.poses], float
    ).reshape(nmocap, 3)
    quat = np.array(
        [[p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z] for p in poses.poses]
    )
    norms = np.linalg.norm(quat.reshape(nmocap, 4), axis=1, keepdims=True)
    if not (np.isfinite(pos).all() and np.isfinite(norms).all() and (norms > 1e-6).all()):
        raise JudoError(
            "a PoseArray with a non-finite position or an orientation that is not a quaternion"
        )
    return pos, quat.reshape(nmocap, 4) / norms


def commands(action: np.ndarray) -> msg.Float64MultiArray:
    """The Float64MultiArray of the (nu,) `action`, one dimension labelled "actuators"."""
    n = len(action)
    layout = msg.MultiArrayLayout([msg.MultiArrayDimension("actuators", n, n)], 0)
    return msg.Float64MultiArray(layout, np.asarray(action, float).tolist())


APPLIED_SUFFIX = "_applied"
"""The applied commands' topic is the commands' topic with this suffix: /judo/commands ->
/judo/commands_applied."""


def applied(names: list[str], action: np.ndarray, stamp: float) -> msg.JointState:
    """The plant's record of a command it applied: a JointState named by the actuators (`names`),
    the (nu,) `action` in `effort` (each actuator's own units) and no positions or velocities,
    stamped `stamp` seconds, the plant's time at the start of the first step it was in force."""
    return msg.JointState(
        msg.Header(msg.stamp_of(stamp), ""), list(names), [], [], np.asarray(action, float).tolist()
    )
