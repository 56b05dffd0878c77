# pyright: reportAttributeAccessIssue=false
# (a message's fields are its IDL dataclass's; cyclonedds types them loosely)
"""`UnitreeSystem`: a Unitree Go2 or G1 under low-level control, over Unitree's own DDS messages, as
judo's `System`.

    python -m judo --task go2_stand --system unitree --headless [--unitree.interface eth0] [--unitree.robot g1]

In: `rt/lowstate` (LowState_) becomes a reading with no `state`: the task's measured sensors (joint
q and dq of each actuator's motor, the IMU's quaternion [w x y z], gyroscope and accelerometer, the
Go2's foot forces), stamped by the robot's tick (milliseconds, made a reading time that never runs
back: `judo.ros2.clock.RobotClock`), with the tick and judo's receive time (monotonic seconds) in
the reading's metadata["tick"] and ["received"]; the task's estimator makes the state.
`rt/sportmodestate` is never read: a robot under low-level control does not publish it.

Out: `rt/lowcmd` (LowCmd_) once per `step()`, at `rate_hz`, with the action in force (the plan
evaluated at each step) as each motor's target q, dq = tau = 0, kp and kd from the model's position
actuators, mode 0x01, Unitree's header fields and CRC (`judo.unitree.crc`). A soft start ramps
targets and gains in from the robot's pose over `soft_start_s`: at the first command, after `halt()`
and after a silence.

`halt()` sends Unitree's damping (kp = 0, kd = `DAMPING_KD`, tau = 0) and keeps sending it until the
next `apply`. The same damping goes out while no valid reading has come for `silence_s` seconds, so
a robot whose readings stopped (or whose process died) never gets a stiff command from a plan made
before. A reading with a non-finite value, the wrong number of motors, a joint where the robot
cannot be (`judo.ros2.joints.JointLayout`) or a tick that runs backwards is refused, and the reason
logged (once, then every few seconds with a count).

The remote's stop: a LowState_ whose `wireless_remote` shows L2 and B held together (`REMOTE_STOP`,
Unitree's own damping combination) latches judo's stop (`judo.safety.stop.wire_request`) at every
such reading, refused or not; the remote never clears it (the GUI's Clear stop button does).
"""  # noqa: E501

import logging
import math
import threading
import time
from typing import Any, NamedTuple

import numpy as np

from judo.core.errors import ConfigError, JudoError
from judo.core.reading import SystemState
from judo.core.task import Task
from judo.loop.mujoco_warnings import count_mujoco_warnings
from judo.loop.system import System
from judo.ros2 import link as ros2_link
from judo.ros2.clock import RobotClock
from judo.ros2.options import UnitreeOptions
from judo.ros2.refusals import Refusals
from judo.safety.stop import wire_request
from judo.unitree import crc
from judo.unitree import motors as mt
from judo.unitree.link import COMMAND_QOS, STATE_QOS, Link
from judo.unitree.messages import LOWCMD, LOWSTATE

logger = logging.getLogger("judo.unitree")

REMOTE_KEYS = (
    "R1",
    "L1",
    "start",
    "select",
    "R2",
    "L2",
    "F1",
    "F2",
    "A",
    "B",
    "X",
    "Y",
    "up",
    "right",
    "down",
    "left",
)
"""The remote's keys by bit of its 16-bit key field: bytes 2 and 3 (little-endian) of a LowState_'s
40 `wireless_remote` bytes (Unitree's xRockerBtnDataStruct: 2 head bytes, the keys, then the
sticks)."""
REMOTE_STOP = frozenset({"L2", "B"})
"""The keys that, held together, latch judo's stop."""
REMOTE_SOURCE = "the Unitree remote (L2+B)"
"""How the latched stop names a latch from the remote."""


class UnitreeSystem(System):
    """A Unitree robot driven by judo's closed loop.

    Args:
        task: the task the robot runs; its model's actuators are the robot's motors
            (`judo.unitree.motors.Motors`) and its `measured_sensors` what a reading holds.
        options: robot, domain, interface, rate, soft start (`judo.ros2.options.UnitreeOptions`).
        refuse_other_writer: raise JudoError at start when another process already writes rt/lowcmd.

    Waits up to `options.wait_s` for the robot's first valid LowState_ (JudoError if none came).

    Attributes:
        motors: the model's actuators as the robot's motors.
        refused: {reason kind: count} of the readings refused so far.
        commands_sent: LowCmd_ messages written so far; `damping_sent` how many of them were
            damping.
    """

    def __init__(
        self, task: Task, options: UnitreeOptions | None = None, refuse_other_writer: bool = True
    ) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader

        self.task = task
        self.options = options = options or UnitreeOptions()
        for name in ("rate_hz", "wait_s", "silence_s"):
            value = getattr(options, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(
                    f"--unitree.{name.replace('_', '-')} must be a positive number, got {value}"
                )
        if not (math.isfinite(options.soft_start_s) and options.soft_start_s >= 0):
            raise ConfigError(
                f"--unitree.soft-start-s must be 0 or more seconds, got {options.soft_start_s}"
            )
        self.timestep = 1.0 / options.rate_hz
        self.motors = mt.Motors.of(task.model, options.robot)
        if task.command_size != self.motors.count:
            raise ConfigError(
                f"{type(task).__name__} commands {task.command_size} values, but its model "
                f"has {self.motors.count} "
                "motors: --system unitree serves one target position per motor"
            )
        if task.measured.size == 0:
            raise ConfigError(
                f"{type(task).__name__} declares no measured sensors; a Unitree robot gives no "
                "state"
            )
        self.sensors = mt.Sensors.of(task.model, task.measured, self.motors)
        self._refusals = Refusals(logger)
        self.refused = self._refusals.counts
        self.commands_sent = self.damping_sent = 0
        self._lock = threading.Lock()
        self._clock = RobotClock()
        self._reading: SystemState | None = None
        self._q = np.zeros(self.motors.count)  # the latest valid reading's motor positions
        self._last_valid = -math.inf  # monotonic time of the latest valid reading
        self._mode_machine = 0  # the G1's, echoed in each command
        self._command: np.ndarray | None = None
        self._halted = False
        # (start, pose) of the soft start under way
        self._ramp: tuple[float, np.ndarray] | None = None
        self._next_tick: float | None = None
        self._closed = False
        count_mujoco_warnings()
        robot = self.motors.robot
        self.link = Link(options.domain, options.interface, robot.low_state, robot.low_cmd)
        try:
            part = self.link.participant
            self._reader = DataReader(part, self.link.state_topic, STATE_QOS)
            self._writer = DataWriter(part, self.link.command_topic, COMMAND_QOS)
            others = Qos(Policy.Reliability.BestEffort, Policy.IgnoreLocal.Participant)
            # other processes' command writers
            self._others = DataReader(part, self.link.command_topic, others)
            self._wait_for_robot(options.wait_s)
            if refuse_other_writer:
                self._refuse_other_writer()
        except BaseException:
            self.link.close()
            raise

    @classmethod
    def from_options(cls, task: Task, options: Any) -> "UnitreeSystem":
        """The bridge the app's `--system unitree [--unitree.*]` options describe (a
        `judo.system_choice.SystemOptions`: its `unitree` and `record`)."""
        if options.record is not None:
            raise ConfigError(
                f"--record {options.record} logs the ROS 2 bridge's link; --system unitree has none"
            )
        return cls(task, options.unitree)

    def _wait_for_robot(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._take()
            if self._reading is not None:
                return
            time.sleep(0.005)
        why = self._refusals.summary()
        raise JudoError(
            f"no valid {self.motors.robot.low_state.__idl_typename__} on {LOWSTATE} in DDS "
            f"domain {self.link.domain} "
            f"within {seconds:g} s ({why}); is the robot on, in low-level mode (sport mode "
            "off), on this domain and "
            f"interface ({self.options.interface or 'the default'})?"
        )

    def _refuse_other_writer(self, seconds: float = 0.3) -> None:
        deadline = time.monotonic() + seconds
        while not self._others.get_matched_publications() and time.monotonic() < deadline:
            time.sleep(0.02)
        if self._others.get_matched_publications():
            raise JudoError(
                "another participant (Unitree's sport service, a judo, a teleop) already "
                f"writes {LOWCMD} in DDS "
                f"domain {self.link.domain}: two controllers would fight over the robot; "
                "stop it (sport mode off)"
            )

    def _refuse(self, kind: str, detail: str) -> None:
        self._refusals.note(kind, detail)

    def _take(self) -> None:
        """Read every LowState_ that arrived since the last call."""
        for message in ros2_link.take(self._reader, 8):
            self._note(message, time.monotonic())

    def _note(self, message, wall: float) -> None:
        if REMOTE_STOP <= remote_keys(message.wireless_remote):
            wire_request(True, REMOTE_SOURCE)
        parsed = reading_of(message, self.motors, self.sensors)
        if isinstance(parsed, Refusal):
            return self._refuse(parsed.kind, parsed.why)
        sensors, q = parsed
        reading_time, why = self._clock.accept(int(message.tick) / 1000.0, wall)
        if reading_time is None:
            return self._refuse("lowstate (tick)", str(why))
        with self._lock:
            metadata = {"tick": int(message.tick), "received": wall}
            self._reading = SystemState(None, reading_time, metadata, sensors)
            self._q, self._last_valid = q, wall
            self._mode_machine = int(getattr(message, "mode_machine", 0))

    def reset(self) -> None:
        """A robot is not reset by judo: the loop starts again from its latest reading."""

    def read_state(self) -> SystemState:
        self._take()
        with self._lock:
            reading = self._reading
        assert reading is not None  # the constructor waited for the first one
        sensors = reading.sensors
        return SystemState(
            None, reading.time, dict(reading.metadata), None if sensors is None else sensors.copy()
        )

    def apply(self, action: np.ndarray) -> None:
        """Keep the (nu,) target positions `action`, clamped to the task's command range, to be sent
        by `step`; after a `halt()`, a soft start from the robot's pose begins. JudoError for a
        wrong size or a non-finite value (nothing is kept then)."""
        action = np.asarray(action, dtype=float)
        size = self.motors.count
        if action.shape != (size,) or not np.isfinite(action).all():
            raise JudoError(
                f"refused a command of shape {action.shape} (expected ({size},), finite): {action}"
            )
        low, high = self.task.command_range.T
        with self._lock:
            self._command = np.clip(action, low, high)
            if self._halted:
                self._halted, self._ramp = False, None

    def step(self) -> None:
        """Send the command in force (ramped in, or damping), then wait for the next tick of the
        rate, in wall time."""
        self._take()
        self._send(time.monotonic())
        now = time.monotonic()
        # first tick, or far behind: pace from now
        if self._next_tick is None or self._next_tick < now - 0.1:
            self._next_tick = now
        self._next_tick += self.timestep
        time.sleep(max(0.0, self._next_tick - time.monotonic()))

    def _send(self, now: float) -> None:
        motors = self.motors
        with self._lock:
            silent = now - self._last_valid > self.options.silence_s
            if silent or self._halted or self._command is None:
                self._ramp = None  # the next command ramps in again from the pose then
                command = None
            else:
                if self._ramp is None:
                    self._ramp = (now, self._q.copy())
                start, pose = self._ramp
                command = self._command
            mode_machine = self._mode_machine
        if command is None:
            return self._write(damping(motors, mode_machine), damping=True)
        soft = self.options.soft_start_s
        s = 1.0 if soft <= 0 else min(1.0, (now - start) / soft)
        q = pose + s * (command - pose)
        kd = mt.DAMPING_KD + s * (motors.kd - mt.DAMPING_KD)
        self._write(mt.low_cmd(motors, q, s * motors.kp, kd, mode_machine))

    def _write(self, message, damping: bool = False) -> None:
        self._writer.write(crc.with_crc(message))
        self.commands_sent += 1
        self.damping_sent += damping

    def halt(self) -> bool:
        """Send Unitree's damping now, and keep sending it until the next `apply`. True."""
        with self._lock:
            self._halted, self._ramp = True, None
            mode_machine = self._mode_machine
        self._write(damping(self.motors, mode_machine), damping=True)
        return True

    def close(self) -> None:
        """Send damping, wait briefly for the robot to acknowledge it, and leave the DDS domain. The
        bridge cannot be used after."""
        from cyclonedds.util import duration

        if self._closed:
            return
        self._closed = True
        self.halt()
        try:
            self._writer.wait_for_acks(duration(milliseconds=200))
        except Exception:  # no reader, or the robot gone: nothing to wait for
            pass
        self.link.close()


def damping(motors: mt.Motors, mode_machine: int = 0):
    """Unitree's damping mode for `motors` (kp = 0, kd = `DAMPING_KD`, tau = 0), as a LowCmd_
    without its CRC."""
    zeros = np.zeros(motors.count)
    return mt.low_cmd(motors, zeros, zeros, np.full(motors.count, mt.DAMPING_KD), mode_machine)


def remote_keys(wireless_remote) -> frozenset[str]:
    """The remote's keys held (names of REMOTE_KEYS) in a LowState_'s (40,) `wireless_remote`
    bytes."""
    raw = bytes(wireless_remote)
    bits = int.from_bytes(raw[2:4], "little") if len(raw) >= 4 else 0
    return frozenset(key for i, key in enumerate(REMOTE_KEYS) if bits >> i & 1)


class Refusal(NamedTuple):
    """Why a reading was refused: its kind (the key of `UnitreeSystem.refused`) and the detail
    logged."""

    kind: str
    why: str


def reading_of(
    message, motors: mt.Motors, sensors: mt.Sensors
) -> tuple[np.ndarray, np.ndarray] | Refusal:
    """((measured size,) the task's measured sensors, (nu,) motor q) of a LowState_ `message`, or
    the `Refusal` of one that cannot be the robot's: the wrong number of motors, a non-finite value,
    a joint out of its bounds."""
    slots = motors.robot.slots
    if len(message.motor_state) != slots:
        return Refusal(
            "lowstate (motor count)",
            f"{len(message.motor_state)} motors; a {motors.robot.name} sends {slots}",
        )
    q, dq, _ = mt.motors_of(message, motors)
    imu = message.imu_state
    values = {
        "quat": np.array(imu.quaternion, float),
        "gyro": np.array(imu.gyroscope, float),
        "acc": np.array(imu.accelerometer, float),
    }
    feet = np.array(getattr(message, "foot_force", [0, 0, 0, 0]), float)
    bad = [
        motors.joints.names[i]
        for i, v in zip(motors.order, q + dq, strict=True)
        if not math.isfinite(v)
    ]
    bad += [f"imu {key}" for key, value in values.items() if not np.isfinite(value).all()]
    if bad:
        return Refusal("lowstate (non-finite)", f"non-finite values of {', '.join(bad)}")
    norm = float(np.linalg.norm(values["quat"]))
    if not 0.5 < norm < 1.5:
        return Refusal(
            "lowstate (imu)",
            f"an IMU quaternion {values['quat'].tolist()} of norm {norm:.3g}, not a unit one",
        )
    why = motors.joints.implausible(motors.order, q, dq)
    if why is not None:
        return Refusal("lowstate (out of bounds)", why)
    values["quat"] = values["quat"] / norm
    return sensors.from_lowstate(q, dq, values, feet), q
