# pyright: reportAttributeAccessIssue=false
# (a message's fields are its IDL dataclass's; cyclonedds types them loosely)
"""A task's model as a Unitree robot's motors: which motor slot each actuator drives, the PD gains
and torque limits the model carries, and the measured sensors as a `rt/lowstate` carries them. Both
ends of the link use it: the bridge (`judo.unitree.bridge`) and the robot process
(`judo.unitree.robot`).

Each actuator is mapped by its joint's name to Unitree's motor index (`GO2_JOINTS`, `G1_JOINTS`); a
model may drive a subset of the motors (the others are sent Unitree's stop values). The planning
model's actuators are position actuators carrying the robot's PD: kp = actuator_gainprm[:, 0], kd =
-actuator_biasprm[:, 2], forcerange the motor's torque limit.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.errors import ConfigError
from judo.core.sensors import MeasuredLayout
from judo.ros2.joints import JointLayout
from judo.unitree import messages as msg

GO2_JOINTS = tuple(
    f"{leg}_{part}_joint" for leg in ("FR", "FL", "RR", "RL") for part in ("hip", "thigh", "calf")
)
"""The Go2's joints in Unitree's motor order (motors 0..11)."""
_G1_LEG = ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
_G1_ARM = (
    "shoulder_pitch",
    "shoulder_roll",
    "shoulder_yaw",
    "elbow",
    "wrist_roll",
    "wrist_pitch",
    "wrist_yaw",
)
G1_JOINTS = (
    *(f"{side}_{j}_joint" for side in ("left", "right") for j in _G1_LEG),
    *(f"waist_{j}_joint" for j in ("yaw", "roll", "pitch")),
    *(f"{side}_{j}_joint" for side in ("left", "right") for j in _G1_ARM),
)
"""The 29-DoF G1's joints in Unitree's motor order (left leg 0-5, right leg 6-11, waist 12-14, left
arm 15-21, right arm 22-28)."""
FEET = ("FR", "FL", "RR", "RL")
"""The Go2's foot_force order; a `touch` sensor named foot_force_<FOOT> is read from (and written
to) its slot."""
ENABLE = 0x01
"""A motor's mode under low-level control (Unitree's PMSM servo mode)."""
POS_STOP, VEL_STOP = 2.146e9, 16000.0
"""What Unitree's Go2 examples send a motor they do not drive: q and dq beyond any target, kp = kd =
0."""
DAMPING_KD = 2.0
"""kd (N m s/rad) of Unitree's damping mode (kp = 0, tau = 0): what `halt()` and a silent link
get."""


@dataclass(frozen=True)
class Robot:
    """One kind of Unitree robot on the wire."""

    name: str
    joints: tuple[str, ...]
    low_cmd: type
    low_state: type
    slots: int
    feet: tuple[str, ...]


ROBOTS = {
    "go2": Robot("go2", GO2_JOINTS, msg.GoLowCmd, msg.GoLowState, msg.GO_MOTORS, FEET),
    "g1": Robot("g1", G1_JOINTS, msg.HgLowCmd, msg.HgLowState, msg.HG_MOTORS, ()),
}
"""--unitree.robot names -> their messages and motor order."""


def robot_named(name: str) -> Robot:
    if name not in ROBOTS:
        raise ConfigError(f"--unitree.robot must be one of {', '.join(ROBOTS)}, got {name!r}")
    return ROBOTS[name]


@dataclass(frozen=True)
class Motors:
    """The model's actuators as the robot's motors, in actuator order.

    Attributes:
        robot: the robot's kind.
        slot: (nu,) int, each actuator's motor index in the messages.
        qpos, qvel: (nu,) int, each actuator's joint's qpos and dof address.
        kp, kd: (nu,) the PD gains of the model's position actuators.
        force_low, force_high: (nu,) each motor's torque limits (N m).
        joints: the joints' layout and bounds (`judo.ros2.joints.JointLayout`); `order` (nu,) each
            actuator's index in it, for its plausibility checks.
    """

    robot: Robot
    slot: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    force_low: np.ndarray
    force_high: np.ndarray
    joints: JointLayout
    order: list[int]

    @classmethod
    def of(cls, model: mujoco.MjModel, robot: str) -> "Motors":
        """The motors of `model` on `robot` ("go2" or "g1"). ConfigError for an actuator not on one
        of the robot's joints, two on one joint, one that is not a position actuator, or one without
        a force range."""
        kind = robot_named(robot)
        layout = JointLayout.of(model)
        slots, kp, kd, low, high, order = [], [], [], [], [], []
        for i in range(model.nu):
            name = model.actuator(i).name or f"actuator{i}"
            joint = int(model.actuator_trnid[i, 0])
            joint_name = (
                mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) if joint >= 0 else None
            )
            if (
                int(model.actuator_trntype[i]) != mujoco.mjtTrn.mjTRN_JOINT
                or joint_name not in kind.joints
            ):
                raise ConfigError(
                    f"actuator {name!r} drives {joint_name!r}, not one of the {kind.name}'s joints "
                    f"{', '.join(kind.joints)}"
                )
            gain, bias = model.actuator_gainprm[i], model.actuator_biasprm[i]
            if not (gain[0] > 0 and np.isclose(bias[1], -gain[0]) and bias[2] <= 0):
                raise ConfigError(
                    f"actuator {name!r} is not a position actuator (<position kp=.. kv=..>): "
                    f"the {kind.name}'s motors "
                    "run a PD on a target, so judo reads kp and kd from it"
                )
            if not model.actuator_forcelimited[i]:
                raise ConfigError(
                    f"actuator {name!r} has no forcerange: give it the motor's torque limit"
                )
            slots.append(kind.joints.index(joint_name))
            kp.append(float(gain[0]))
            kd.append(float(-bias[2]))
            low.append(float(model.actuator_forcerange[i, 0]))
            high.append(float(model.actuator_forcerange[i, 1]))
            order.append(layout.model_names.index(joint_name))
        if len(set(slots)) != len(slots):
            raise ConfigError(
                f"two actuators drive one joint of the {kind.name}: motor slots {slots}"
            )
        return cls(
            kind,
            np.array(slots, int),
            layout.qpos[order],
            layout.qvel[order],
            np.array(kp),
            np.array(kd),
            np.array(low),
            np.array(high),
            layout,
            order,
        )

    @property
    def count(self) -> int:
        return len(self.slot)


@dataclass(frozen=True)
class Sensors:
    """Where each measured sensor of a task comes from in a `rt/lowstate`.

    Attributes:
        entries: (slice of the measured vector, kind, index) of each sensor: kind "q"
            or "dq" (index: the actuator, in `Motors` order), "quat", "gyro", "acc" (index 0)
            or "foot" (index: the foot_force slot).
        size: the measured vector's length.
    """

    entries: tuple[tuple[slice, str, int], ...]
    size: int

    @classmethod
    def of(cls, model: mujoco.MjModel, measured: MeasuredLayout, motors: Motors) -> "Sensors":
        """The sources of `measured` (a task's measured layout on `model`). ConfigError for a sensor
        a lowstate does not carry."""
        by_joint = {
            int(model.jnt_qposadr[int(model.actuator_trnid[i, 0])]): i for i in range(model.nu)
        }
        kinds = {"framequat": "quat", "gyro": "gyro", "accelerometer": "acc"}
        entries = []
        for name, kind, sensor, where in zip(
            measured.names, measured.types, measured.ids, measured.slices, strict=True
        ):
            if kind in ("jointpos", "jointvel"):
                address = int(model.jnt_qposadr[model.sensor_objid[sensor]])
                if address not in by_joint:
                    raise ConfigError(
                        f"measured sensor {name!r} is on a joint no actuator drives, so no "
                        "motor reads it"
                    )
                entries.append((where, "q" if kind == "jointpos" else "dq", by_joint[address]))
            elif kind in kinds:
                entries.append((where, kinds[kind], 0))
            elif kind == "touch" and name.rpartition("_")[2] in motors.robot.feet:
                entries.append((where, "foot", motors.robot.feet.index(name.rpartition("_")[2])))
            else:
                raise ConfigError(
                    f"measured sensor {name!r} ({kind}) is not in a {motors.robot.name}'s "
                    "rt/lowstate, which carries "
                    "jointpos, jointvel, framequat, gyro, accelerometer"
                    + (" and touch sensors foot_force_FR/_FL/_RR/_RL" if motors.robot.feet else "")
                )
        return cls(tuple(entries), measured.size)

    def from_lowstate(
        self, q: np.ndarray, dq: np.ndarray, imu: dict[str, np.ndarray], feet: np.ndarray
    ) -> np.ndarray:
        """(size,) the measured vector of (nu,) motor `q`, `dq`, the `imu` ("quat" (4,) w x y z,
        "gyro", "acc" (3,)) and (4,) `feet` forces in newtons."""
        values = np.empty(self.size)
        for where, kind, i in self.entries:
            values[where] = (
                q[i]
                if kind == "q"
                else dq[i]
                if kind == "dq"
                else feet[i]
                if kind == "foot"
                else imu[kind]
            )
        return values

    def imu_and_feet(self, values: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """(imu, (4,) feet) out of a (size,) measured vector (the robot side: what it publishes);
        what the task does not measure is the IMU at rest ([1, 0, 0, 0], zeros) and no force."""
        imu = {"quat": np.array([1.0, 0, 0, 0]), "gyro": np.zeros(3), "acc": np.zeros(3)}
        feet = np.zeros(4)
        for where, kind, i in self.entries:
            if kind in imu:
                imu[kind] = values[where]
            elif kind == "foot":
                feet[i] = values[where][0]
        return imu, feet


def motors_of(message, motors: Motors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """((nu,) q, dq, tau_est) of the model's motors in a lowstate `message`."""
    states = message.motor_state
    q = np.array([states[s].q for s in motors.slot], float)
    dq = np.array([states[s].dq for s in motors.slot], float)
    tau = np.array([states[s].tau_est for s in motors.slot], float)
    return q, dq, tau


def low_cmd(motors: Motors, q: np.ndarray, kp: np.ndarray, kd: np.ndarray, mode_machine: int = 0):
    """A LowCmd_ for `motors` with (nu,) targets `q` and gains `kp`, `kd` (dq = tau = 0), header
    fields as Unitree's low-level examples set them, its CRC not yet set
    (`judo.unitree.crc.with_crc`). The G1's must echo the robot's `mode_machine`."""
    robot = motors.robot
    message = robot.low_cmd()
    if robot.name == "go2":
        message.head = bytes([0xFE, 0xEF])
        message.level_flag = 0xFF  # low-level control
        for cmd in message.motor_cmd:
            cmd.mode, cmd.q, cmd.dq = ENABLE, POS_STOP, VEL_STOP
    else:
        message.mode_pr, message.mode_machine = 0, int(mode_machine)
    for i, slot in enumerate(motors.slot.tolist()):
        cmd = message.motor_cmd[slot]
        cmd.mode, cmd.q, cmd.dq, cmd.tau = ENABLE, float(q[i]), 0.0, 0.0
        cmd.kp, cmd.kd = float(kp[i]), float(kd[i])
    return message


def targets_of(message, motors: Motors) -> np.ndarray:
    """(5, nu) [q, dq, tau, kp, kd] of the model's motors in a LowCmd_ `message`."""
    cmds = [message.motor_cmd[s] for s in motors.slot]
    return np.array([[c.q, c.dq, c.tau, c.kp, c.kd] for c in cmds], float).T.reshape(
        5, motors.count
    )
