"""A MuJoCo model's joints as a robot's ROS 2 messages name them: what the bridge, the plant and the MCAP reader
share. It needs no DDS: a decoded message is read by its fields, whichever library decoded it."""

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError


@dataclass(frozen=True)
class JointLayout:
    """A model's joints as a robot names them in its JointState, and where each sits in [qpos, qvel].

    Attributes:
        names: (k,) the robot's names of the model's hinge and slide joints, in model order.
        model_names: (k,) their MJCF names.
        qpos: (k,) int, each joint's qpos address.
        qvel: (k,) int, each joint's dof address.
        free: (qpos address, dof address) of the model's free joint (the base, in /odom), or None.
    """

    names: tuple[str, ...]
    model_names: tuple[str, ...]
    qpos: np.ndarray
    qvel: np.ndarray
    free: tuple[int, int] | None

    @classmethod
    def of(cls, model: mujoco.MjModel, joint_map: tuple[str, ...] = ()) -> "JointLayout":
        """The layout of `model`; `joint_map` holds "mjcf_name=robot_name" entries for names that differ.
        ConfigError for a ball joint, a second free joint or a map entry naming no joint."""
        mapping: dict[str, str] = {}
        for entry in joint_map:
            model_name, sep, robot_name = entry.partition("=")
            if not sep or not model_name or not robot_name:
                raise ConfigError(f"a joint map entry must read mjcf_name=robot_name, got {entry!r}")
            mapping[model_name] = robot_name
        names, model_names, qpos, qvel, free = [], [], [], [], None
        all_names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j in range(model.njnt)]
        for unknown in sorted(set(mapping) - set(all_names)):
            raise ConfigError(f"the joint map names {unknown!r}, which the model lacks; its joints: {all_names}")
        for j, name in enumerate(all_names):
            kind = int(model.jnt_type[j])
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                if free is not None:
                    raise ConfigError(f"a robot link carries one free joint (the base in /odom); {name!r} is a second")
                free = (int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]))
            elif kind == mujoco.mjtJoint.mjJNT_BALL:
                raise ConfigError(f"ball joint {name!r} has no JointState form; only hinge, slide and one free joint")
            else:
                names.append(mapping.get(name, name))
                model_names.append(name)
                qpos.append(int(model.jnt_qposadr[j]))
                qvel.append(int(model.jnt_dofadr[j]))
        return cls(tuple(names), tuple(model_names), np.array(qpos, int), np.array(qvel, int), free)


def base_from_odometry(odom: Any) -> tuple[np.ndarray, np.ndarray]:
    """((7,) free-joint qpos [x y z qw qx qy qz], (6,) qvel [world linear, body angular]) of `odom`, a
    nav_msgs/Odometry (judo.ros2.messages' class, or one an MCAP reader decoded)."""
    p, q = odom.pose.pose.position, odom.pose.pose.orientation
    quat = np.array([q.w, q.x, q.y, q.z])
    norm = float(np.linalg.norm(quat))
    if not math.isfinite(norm) or norm < 1e-6:
        raise JudoError(f"an Odometry with orientation {quat.tolist()} (not a unit quaternion)")
    quat /= norm
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    t = odom.twist.twist
    linear = rot.reshape(3, 3) @ np.array([t.linear.x, t.linear.y, t.linear.z])
    qpos = np.concatenate([[p.x, p.y, p.z], quat])
    return qpos, np.concatenate([linear, [t.angular.x, t.angular.y, t.angular.z]])
