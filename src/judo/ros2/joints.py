"""A MuJoCo model's joints as a robot's ROS 2 messages name them, and the readings a robot cannot
give (a joint beyond its range with a margin, faster than the model can move it): what the bridge,
the plant and the MCAP reader share. It needs no DDS: a decoded message is read by its fields,
whichever library decoded it."""

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError

RANGE_MARGIN = 0.1
"""Fraction of a limited joint's range a reading may lie beyond either end of it: a joint pressed
into its stop overshoots it by the stop's compliance, a few percent at most, and a calibration is
rarely further off."""
MAX_UNLIMITED = 1e6
"""Largest |position| of an unlimited joint and of a free base, in rad or m (160,000 turns, 1,000
km): far beyond any robot's, and far below MuJoCo's "huge value" of 1e10, which a rollout from such
a state soon meets."""


@dataclass(frozen=True)
class JointLayout:
    """A model's joints as a robot names them in its JointState, and where each sits in [qpos,
    qvel].

    Attributes:
        names: (k,) the robot's names of the model's hinge and slide joints, in model order.
        model_names: (k,) their MJCF names.
        qpos: (k,) int, each joint's qpos address.
        qvel: (k,) int, each joint's dof address.
        free: (qpos address, dof address) of the model's free joint (the base, in /odom), or None.
        low, high: (k,) the positions each joint can be at: a limited joint's range widened
            by `RANGE_MARGIN` of it at either end, else -/+`MAX_UNLIMITED`.
        max_speed: (k,) the speed no actuator gives a joint (rad/s or m/s): the speed that in one
            physics step of the model crosses its whole range (a limited joint), half a turn (a
            hinge: faster, a sampled angle is aliased) or the model's extent (`model.stat.extent`,
            an unlimited slide), whichever is least.
        kinds: (k,) "hinge" or "slide".
        bases: (k,) (what `low` and `high` are, what `max_speed` is) of each joint, in words, for
            messages.
    """

    names: tuple[str, ...]
    model_names: tuple[str, ...]
    qpos: np.ndarray
    qvel: np.ndarray
    free: tuple[int, int] | None
    low: np.ndarray
    high: np.ndarray
    max_speed: np.ndarray
    kinds: tuple[str, ...]
    bases: tuple[tuple[str, str], ...]

    @classmethod
    def of(cls, model: mujoco.MjModel, joint_map: tuple[str, ...] = ()) -> "JointLayout":
        """The layout of `model`; `joint_map` holds "mjcf_name=robot_name" entries for names that
        differ. ConfigError for a ball joint, a second free joint or a map entry naming no joint."""
        mapping: dict[str, str] = {}
        for entry in joint_map:
            model_name, sep, robot_name = entry.partition("=")
            if not sep or not model_name or not robot_name:
                raise ConfigError(
                    f"a joint map entry must read mjcf_name=robot_name, got {entry!r}"
                )
            mapping[model_name] = robot_name
        names, model_names, qpos, qvel, free, joints = [], [], [], [], None, []
        all_names = [
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
            for j in range(model.njnt)
        ]
        for unknown in sorted(set(mapping) - set(all_names)):
            raise ConfigError(
                f"the joint map names {unknown!r}, which the model lacks; its joints: {all_names}"
            )
        for j, name in enumerate(all_names):
            kind = int(model.jnt_type[j])
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                if free is not None:
                    raise ConfigError(
                        f"a robot link carries one free joint (the base in /odom); {name!r} is a "
                        "second"
                    )
                free = (int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]))
            elif kind == mujoco.mjtJoint.mjJNT_BALL:
                raise ConfigError(
                    f"ball joint {name!r} has no JointState form; only hinge, slide and one free "
                    "joint"
                )
            else:
                names.append(mapping.get(name, name))
                model_names.append(name)
                qpos.append(int(model.jnt_qposadr[j]))
                qvel.append(int(model.jnt_dofadr[j]))
                joints.append(j)
        low, high, speed, kinds, bases = _bounds(model, joints)
        return cls(
            tuple(names),
            tuple(model_names),
            np.array(qpos, int),
            np.array(qvel, int),
            free,
            low,
            high,
            speed,
            kinds,
            bases,
        )

    def implausible(
        self, order: list[int], position: np.ndarray, velocity: np.ndarray
    ) -> str | None:
        """Why the (n,) `position` and `velocity` of a JointState (in message order; `order` their
        indices in this layout) cannot be the robot's, naming each joint outside `low`..`high` or
        beyond `max_speed` and the bound's basis; None if they can be."""
        bad = []
        for i, p, v in zip(order, position.tolist(), velocity.tolist(), strict=True):
            unit, (where, how_fast) = ("rad" if self.kinds[i] == "hinge" else "m"), self.bases[i]
            if not self.low[i] <= p <= self.high[i]:
                bad.append(
                    f"joint {self.names[i]!r} position {p:.6g} {unit} is outside "
                    f"{self.low[i]:.6g} to "
                    f"{self.high[i]:.6g} ({where})"
                )
            if not abs(v) <= self.max_speed[i]:
                bad.append(
                    f"joint {self.names[i]!r} velocity {v:.6g} {unit}/s is outside "
                    f"+/-{self.max_speed[i]:.6g} "
                    f"({how_fast})"
                )
        return "; ".join(bad) or None


def _bounds(
    model: mujoco.MjModel, joints: list[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple, tuple]:
    """((k,) low, (k,) high, (k,) max_speed, kinds, bases) of the hinge and slide `joints` (ids), as
    `JointLayout` has them."""
    dt = float(model.opt.timestep)
    low, high, speed, kinds, bases = [], [], [], [], []
    for j in joints:
        hinge = int(model.jnt_type[j]) == mujoco.mjtJoint.mjJNT_HINGE
        kinds.append("hinge" if hinge else "slide")
        travel, how_far = (
            (math.pi, "half a turn") if hinge else (float(model.stat.extent), "the model's extent")
        )
        a, b = (float(x) for x in model.jnt_range[j])
        if model.jnt_limited[j] and b > a:
            low.append(a - RANGE_MARGIN * (b - a))
            high.append(b + RANGE_MARGIN * (b - a))
            where = f"its range {a:.6g} to {b:.6g} with a {RANGE_MARGIN:.0%} margin"
            if b - a < travel:
                travel, how_far = b - a, "its whole range"
        else:
            low.append(-MAX_UNLIMITED)
            high.append(MAX_UNLIMITED)
            where = "an unlimited joint's bound"
        speed.append(travel / dt)
        bases.append((where, f"{how_far} in one {dt:g} s physics step"))
    return np.array(low), np.array(high), np.array(speed), tuple(kinds), tuple(bases)


def base_from_odometry(odom: Any) -> tuple[np.ndarray, np.ndarray]:
    """((7,) free-joint qpos [x y z qw qx qy qz], (6,) qvel [world linear, body angular]) of `odom`,
    a nav_msgs/Odometry (judo.ros2.messages' class, or one an MCAP reader decoded)."""
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


def implausible_base(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray) -> str | None:
    """Why a free base's (7,) `qpos` and (6,) `qvel` (as `base_from_odometry` makes them) cannot be
    the robot's, or None: a position beyond +/-`MAX_UNLIMITED`, a speed that crosses the model's
    extent, or an angular speed that turns half a turn, in one physics step of `model`."""
    dt = float(model.opt.timestep)
    bounds = (
        ("position", float(np.abs(qpos[:3]).max()), MAX_UNLIMITED, "m"),
        ("linear speed", float(np.linalg.norm(qvel[:3])), float(model.stat.extent) / dt, "m/s"),
        ("angular speed", float(np.linalg.norm(qvel[3:6])), math.pi / dt, "rad/s"),
    )
    bad = [
        f"base {what} {value:.6g} {unit} is beyond {bound:.6g}"
        for what, value, bound, unit in bounds
        if value > bound
    ]
    return "; ".join(bad) + f" (physics step {dt:g} s)" if bad else None
