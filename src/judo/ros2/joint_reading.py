"""A robot's sensor_msgs/JointState as the arrays of the ROS 2 bridge's reading
(`judo.ros2.bridge.Ros2System`): the checks that refuse one that cannot be a reading
(`check_joint_state`), the full state it gives with the latest Odometry (`full_state`), and, where
it is not the full state, the task's measured sensors it gives with the latest Imu
(`measured_sensors`). A message is read by its fields, so these need no DDS."""

import math
from typing import Any, NamedTuple

import mujoco
import numpy as np

from judo.core.task import Task
from judo.ros2.joints import JointLayout


class JointArrays(NamedTuple):
    """A JointState's joints as arrays, in the message's order."""

    order: list[int]
    """Each joint's index in the `JointLayout`."""
    position: np.ndarray
    """(n,) the joints' positions."""
    velocity: np.ndarray
    """(n,) the joints' velocities, zeros where the message carried none."""
    with_velocity: bool
    """Whether the message carried a velocity for each joint."""


def check_joint_state(
    joints: Any, layout: JointLayout, index: dict[str, int]
) -> tuple[JointArrays | None, tuple[str, str] | None]:
    """(the arrays of the JointState `joints`, None), or (None, (the refusal's kind, why)) for one
    with wrong lengths, a missing or unknown joint, a non-finite value, or a joint where the robot
    cannot be (`JointLayout.implausible`). `index`: {each of `layout`'s names: its index}."""
    names, n = list(joints.name), len(joints.name)
    with_velocity = len(joints.velocity) == n
    if len(joints.position) != n or not (with_velocity or len(joints.velocity) == 0):
        return None, (
            "joint state (wrong lengths)",
            f"{n} names, {len(joints.position)} positions, {len(joints.velocity)} velocities; "
            "each joint needs a position, and a velocity each or none",
        )
    unknown = [name for name in names if name not in index]
    missing = [name for name in layout.names if name not in set(names)]
    if unknown or missing:
        return None, (
            "joint state (names)",
            f"missing joints {missing}, unknown joints {unknown}; expected "
            f"{list(layout.names)} "
            "(map names with --ros2.joint-map mjcf_name=robot_name)",
        )
    position = np.asarray(joints.position, float)
    velocity = np.asarray(joints.velocity, float) if with_velocity else np.zeros(n)
    bad = [
        name
        for name, p, v in zip(names, position, velocity, strict=True)
        if not math.isfinite(p + v)
    ]
    if bad:
        return None, (
            "joint state (non-finite)",
            f"non-finite position or velocity of joints {bad}",
        )
    order = [index[name] for name in names]
    why = layout.implausible(order, position, velocity)
    if why is not None:
        return None, ("joint state (out of bounds)", why)
    return JointArrays(order, position, velocity, with_velocity), None


def full_state(
    model: mujoco.MjModel,
    layout: JointLayout,
    joints: JointArrays,
    odom: tuple[np.ndarray, np.ndarray] | None,
) -> np.ndarray:
    """(nq + nv,) the state of `model` from the checked `joints` (each velocity given) and, for a
    free base, the latest Odometry's (qpos (7,), qvel (6,)) `odom`; the model's qpos0 and zero
    velocity elsewhere."""
    qpos, qvel = model.qpos0.copy(), np.zeros(model.nv)
    qpos[layout.qpos[joints.order]] = joints.position
    qvel[layout.qvel[joints.order]] = joints.velocity
    if layout.free is not None and odom is not None:
        a, d = layout.free
        qpos[a : a + 7], qvel[d : d + 6] = odom
    return np.concatenate([qpos, qvel])


def measured_sensors(
    task: Task,
    joint_layout: JointLayout,
    position: np.ndarray,
    order: list[int],
    imu: dict[str, np.ndarray] | None,
    odom_topic: str,
) -> tuple[np.ndarray | None, str | None]:
    """((task.measured.size,) the task's measured sensors from the JointState's `position` (in
    message order; `order` their indices in `joint_layout`) and the latest Imu's values `imu` (None:
    none yet), None) or (None, why they cannot be made). `odom_topic`: where the Odometry of a free
    base is read, for the reason."""
    model, layout = task.model, task.measured
    if layout.size == 0:
        return None, (
            f"{type(task).__name__} declares no measured sensors, so each "
            "JointState needs a velocity "
            "per joint"
            + (" and an Odometry on " + odom_topic if joint_layout.free is not None else "")
        )
    by_qpos = dict(zip(joint_layout.qpos[order].tolist(), position.tolist(), strict=True))
    values = np.empty(layout.size)
    for name, kind, sensor, where in zip(
        layout.names, layout.types, layout.ids, layout.slices, strict=True
    ):
        if kind == "jointpos":
            address = int(model.jnt_qposadr[model.sensor_objid[sensor]])
            if address not in by_qpos:
                return None, f"measured sensor {name!r} is on a joint the JointState lacks"
            values[where] = by_qpos[address]
        elif kind in ("gyro", "accelerometer") and imu is not None:
            key = "angular_velocity" if kind == "gyro" else "linear_acceleration"
            values[where] = imu[key]
        else:
            source = (
                "no Imu has arrived yet" if kind in ("gyro", "accelerometer") else "no ROS 2 source"
            )
            return (
                None,
                f"measured sensor {name!r} ({kind}) has {source}; the bridge fills "
                "jointpos, gyro, accelerometer",
            )
    return values, None
