# pyright: reportArgumentType=false
# (cyclonedds types a message's list fields as its IDL `sequence`, which is a plain list at run
# time)
"""`Ros2System`: a robot reached over ROS 2's DDS wire, with no ROS install, as judo's `System`.

    python -m judo --task cartpole --system ros2 --headless [--ros2.domain-id 7] [--record run.mcap]

State in: sensor_msgs/JointState on /joint_states (matched by joint name), nav_msgs/Odometry on
/odom for a task with a free joint, sensor_msgs/Imu on /imu (passed on in the reading's
metadata["imu"]), and for a task with mocap bodies (a goal) geometry_msgs/PoseArray on /judo/mocap
(metadata["mocap_pos"], ["mocap_quat"]); best effort, keep last 1. Commands out:
std_msgs/Float64MultiArray on /judo/commands in actuator order, reliable: what a ros2_control
forward command controller takes. The reading's time is the JointState's header stamp, the robot's
clock, so a late reading is known as late. A JointState with a velocity for every joint (and, for a
free base, an Odometry) is the full state; one with positions only becomes the task's
`measured_sensors` (jointpos from the positions, gyro and accelerometer from the latest Imu) for its
estimator.

A message that cannot be a reading is refused, and the reason is logged (once, then every few
seconds with a count): wrong lengths, a missing or unknown joint, a non-finite value, a joint where
the robot cannot be (beyond its range with a margin, or faster than the model can move it:
`judo.ros2.joints.JointLayout`), a stamp that jumps backwards or from the future. While nothing
valid arrives the reading's time stands still, and the closed loop's watchdog serves the task's safe
action once the plan is older than `max_plan_age`. A robot that restarts its clock is followed after
a second of consistent stamps (`judo.ros2.clock`), with the reading's time carried on from where it
was. When recording, the commands the robot reports it applied (a JointState on <commands>_applied,
as `python -m judo plant` publishes them) are logged too, for `sysid` to pair each step with.
Another commander or a second robot on the topics is refused at start (`judo.ros2.peers`).

The e-stop: a std_msgs/Bool on /judo/estop (reliable), true latches the app's stop and false clears
it (`judo.safety.stop.wire_request`); each is taken when the loop next reads the robot, and logged
when recording."""

import logging
import math
import threading
import time
from typing import Any

import numpy as np

from judo.core.errors import ConfigError, JudoError
from judo.core.reading import SystemState
from judo.core.task import Task
from judo.loop.mujoco_warnings import count_mujoco_warnings
from judo.loop.system import System
from judo.loop.timing import safe_action
from judo.ros2 import link
from judo.ros2 import messages as msg
from judo.ros2.clock import RobotClock
from judo.ros2.joint_reading import check_joint_state, full_state, measured_sensors
from judo.ros2.joints import JointLayout, base_from_odometry, implausible_base
from judo.ros2.mcap_log import LimitHitLog, McapLog, log_metadata
from judo.ros2.options import Ros2Options
from judo.ros2.peers import Peers
from judo.ros2.refusals import Refusals
from judo.safety.stop import wire_request

logger = logging.getLogger("judo.ros2")

ESTOP_TOPIC = "/judo/estop"
"""The ROS 2 topic of the e-stop: std_msgs/Bool, true latches the app's stop, false clears it."""


class Ros2System(System):
    """The robot behind a ROS 2 graph, driven by judo's closed loop.

    Args:
        task: the task the robot runs; its model's joint names are the JointState's (through
            `options.joint_map`), and `halt()` writes its `safe_action`.
        options: domain, topics, rate and joint map (`judo.ros2.options.Ros2Options`).
        record: an MCAP log of every message read and written, and of the commands the robot applied
            (None: none).
        refuse_other_writer: raise JudoError at start when another writer already commands the
            robot, or a second robot publishes joint states (`judo.ros2.peers`); either is warned of
            while running.

    Waits up to `options.wait_s` for the robot's first valid JointState (JudoError if none came).

    Attributes:
        peers: the other processes on its topics (`judo.ros2.peers.Peers`).
        refused: {reason kind: count} of the messages refused so far.
        commands_sent: commands written so far.
    """

    def __init__(
        self,
        task: Task,
        options: Ros2Options | None = None,
        record: McapLog | None = None,
        refuse_other_writer: bool = True,
    ) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader

        self.task = task
        self.options = options = options or Ros2Options()
        if not (math.isfinite(options.rate_hz) and options.rate_hz > 0):
            raise ConfigError(
                f"the bridge's rate must be a positive number of Hz, got {options.rate_hz}"
            )
        self.timestep = 1.0 / options.rate_hz
        self.layout = JointLayout.of(task.model, options.joint_map)
        self.domain = link.domain_id(options.domain_id)
        self.log = record
        self._refusals = Refusals(logger)
        self.refused = self._refusals.counts
        self.commands_sent = 0
        self._index = {name: i for i, name in enumerate(self.layout.names)}
        self._lock = threading.Lock()
        self._clock = RobotClock()
        self._reading: SystemState | None = None
        self._odom: tuple[np.ndarray, np.ndarray] | None = None
        self._imu: dict[str, np.ndarray] | None = None
        # (nmocap, 3), (nmocap, 4) from the robot side
        self._mocap: tuple[np.ndarray, np.ndarray] | None = None
        self._command: np.ndarray | None = None
        self._next_tick: float | None = None
        self._closed = False
        # the planner's rollouts from a reading MuJoCo cannot simulate would flood the terminal
        count_mujoco_warnings()
        self._participant = part = link.participant(self.domain)
        try:
            self._joint_reader = DataReader(
                part, link.topic(part, options.joint_states, msg.JointState), link.SENSOR_QOS
            )
            self._odom_reader = None
            if self.layout.free is not None:
                self._odom_reader = DataReader(
                    part, link.topic(part, options.odom, msg.Odometry), link.SENSOR_QOS
                )
            self._imu_reader = DataReader(
                part, link.topic(part, options.imu, msg.Imu), link.SENSOR_QOS
            )
            self._mocap_reader = None
            if task.model.nmocap:
                mocap_topic = link.topic(part, options.mocap, msg.PoseArray)
                self._mocap_reader = DataReader(part, mocap_topic, link.SENSOR_QOS)
            # reliable and deep: a true then a false both count
            estop_topic = link.topic(part, ESTOP_TOPIC, msg.Bool)
            self._estop_reader = DataReader(part, estop_topic, link.APPLIED_QOS)
            command_topic = link.topic(part, options.commands, msg.Float64MultiArray)
            self._writer = DataWriter(part, command_topic, link.COMMAND_QOS)
            self._applied_reader = None
            # the robot's own record of the commands it applied, only to be logged
            if record is not None:
                applied_topic = link.topic(
                    part, options.commands + link.APPLIED_SUFFIX, msg.JointState
                )
                self._applied_reader = DataReader(part, applied_topic, link.APPLIED_QOS)
            # writers of other processes
            others = Qos(Policy.Reliability.Reliable(0), Policy.IgnoreLocal.Participant)
            topics = (options.commands, options.joint_states)
            self.peers = Peers(
                DataReader(part, command_topic, others), self._joint_reader, topics, self.domain
            )
            self._wait_for_robot(options.wait_s)
            if refuse_other_writer:
                self.peers.refuse_at_start()
        except BaseException:
            link.close_participant(part)
            raise

    @classmethod
    def from_options(cls, task: Task, options: Any) -> "Ros2System":
        """The bridge the app's `--system ros2 [--record FILE.mcap] [--ros2.*]` options describe (a
        `judo.system_choice.SystemOptions`: its `ros2` and `record`)."""
        log = (
            None
            if options.record is None
            else McapLog(options.record, log_metadata(task, options.ros2))
        )
        try:
            return cls(task, options.ros2, log)
        except BaseException:
            if log is not None:
                log.close()
            raise

    def _wait_for_robot(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._take()
            if self._reading is not None:
                return
            time.sleep(0.01)
        why = self._refusals.summary()
        raise JudoError(
            f"no valid sensor_msgs/JointState on {msg.ros_topic(self.options.joint_states)} "
            "in DDS domain "
            f"{self.domain} within {seconds:g} s ({why}); is the robot's process running, on "
            "this ROS_DOMAIN_ID? "
            f"It must name the joints {list(self.layout.names)}"
        )

    def _refuse(self, kind: str, detail: str) -> None:
        self._refusals.note(kind, detail)

    def _take(self) -> None:
        """Read every message that arrived since the last call."""
        wall = time.monotonic()
        if self._odom_reader is not None:
            for odom in link.take(self._odom_reader, 8):
                self._note_odometry(odom)
        for sample in link.take(self._imu_reader, 8):
            self._note_imu(sample)
        for poses in [] if self._mocap_reader is None else link.take(self._mocap_reader, 8):
            try:
                self._mocap = link.mocap_from_poses(poses, self.task.model.nmocap)
            except JudoError as err:
                self._refuse("mocap poses", str(err))
                continue
            if self.log is not None:
                self.log.write(self.options.mocap, poses, _ns(poses.header.stamp))
        for joints in link.take(self._joint_reader, 8):
            self._note_joint_state(joints, wall)
        self._log_applied()

    def _log_applied(self) -> None:
        """Log every applied command the robot reported since the last call (recording only)."""
        if self._applied_reader is None or self.log is None:
            return
        for applied in link.take(self._applied_reader, 256):
            self.log.write(
                self.options.commands + link.APPLIED_SUFFIX, applied, _ns(applied.header.stamp)
            )

    def _note_odometry(self, odom: msg.Odometry) -> None:
        try:
            qpos, qvel = base_from_odometry(odom)
        except JudoError as err:
            return self._refuse("odometry", str(err))
        if not (np.isfinite(qpos).all() and np.isfinite(qvel).all()):
            return self._refuse("odometry", "an Odometry with a non-finite pose or twist")
        why = implausible_base(self.task.model, qpos, qvel)
        if why is not None:
            return self._refuse("odometry (out of bounds)", why)
        if self.log is not None:
            self.log.write(self.options.odom, odom, _ns(odom.header.stamp))
        self._odom = (qpos, qvel)

    def _note_imu(self, sample: msg.Imu) -> None:
        q, w, a = sample.orientation, sample.angular_velocity, sample.linear_acceleration
        values = {
            "orientation": np.array([q.w, q.x, q.y, q.z]),
            "angular_velocity": np.array([w.x, w.y, w.z]),
            "linear_acceleration": np.array([a.x, a.y, a.z]),
            "stamp": np.array([msg.seconds_of(sample.header.stamp)]),
        }
        if not all(np.isfinite(v).all() for v in values.values()):
            return self._refuse("imu", "an Imu with a non-finite value")
        if self.log is not None:
            self.log.write(self.options.imu, sample, _ns(sample.header.stamp))
        self._imu = values

    def _note_joint_state(self, joints: msg.JointState, wall: float) -> None:
        arrays, refusal = check_joint_state(joints, self.layout, self._index)
        if arrays is None:
            assert refusal is not None
            return self._refuse(*refusal)
        full = arrays.with_velocity and (self.layout.free is None or self._odom is not None)
        sensors = None
        # positions only (or no odometry): the task's measured sensors, for its estimator
        if not full:
            sensors, why = measured_sensors(
                self.task, self.layout, arrays.position, arrays.order, self._imu, self.options.odom
            )
            if sensors is None:
                return self._refuse("joint state (not enough to plan from)", str(why))
        reading_time, why = self._clock.accept(msg.seconds_of(joints.header.stamp), wall)
        if reading_time is None:
            return self._refuse("joint state (stamp)", str(why))
        state = full_state(self.task.model, self.layout, arrays, self._odom) if full else None
        metadata: dict[str, Any] = {}
        if self._imu is not None:
            metadata["imu"] = {key: value.copy() for key, value in self._imu.items()}
        if self._mocap is not None:  # as judo's simulator publishes them in-process
            metadata["mocap_pos"], metadata["mocap_quat"] = (value.copy() for value in self._mocap)
        if self.log is not None:
            self.log.write(self.options.joint_states, joints, _ns(joints.header.stamp))
        with self._lock:
            self._reading = SystemState(state, reading_time, metadata, sensors)

    def reset(self) -> None:
        """A robot is not reset by judo: the loop starts again from its latest reading."""

    def recorder(self) -> LimitHitLog | None:
        """When recording, the log of each limit hit of the closed loop on the bridge
        (`LimitHitLog`)."""
        return None if self.log is None else LimitHitLog(self.log)

    def read_state(self) -> SystemState:
        self._take()
        # in the order sent (not while waiting for the robot)
        for estop in link.take(self._estop_reader, 64):
            if self.log is not None:
                self.log.write(ESTOP_TOPIC, estop)
            wire_request(bool(estop.data), ESTOP_TOPIC)
        with self._lock:
            reading = self._reading
        assert reading is not None  # the constructor waited for the first one
        state, sensors = reading.state, reading.sensors
        return SystemState(
            None if state is None else state.copy(),
            reading.time,
            dict(reading.metadata),
            None if sensors is None else sensors.copy(),
        )

    def apply(self, action: np.ndarray) -> None:
        """Keep the (command_size,) `action`, clamped to the task's command range, to be written by
        `step`. JudoError for a wrong size or a non-finite value (nothing is written then)."""
        action = np.asarray(action, dtype=float)
        size = self.task.command_size
        if action.shape != (size,) or not np.isfinite(action).all():
            raise JudoError(
                f"refused a command of shape {action.shape} (expected ({size},), finite): {action}"
            )
        low, high = self.task.command_range.T
        with self._lock:
            self._command = np.clip(action, low, high)

    def step(self) -> None:
        """Write the command in force, then wait for the next tick of the bridge's rate, in wall
        time."""
        with self._lock:
            command = self._command
        if command is not None:
            self._write(command)
        now = time.monotonic()
        self.peers.check(now)
        # first tick, or far behind: pace from now
        if self._next_tick is None or self._next_tick < now - 0.1:
            self._next_tick = now
        self._next_tick += self.timestep
        time.sleep(max(0.0, self._next_tick - time.monotonic()))

    def _write(self, command: np.ndarray) -> None:
        message = link.commands(command)
        self._writer.write(message)
        self.commands_sent += 1
        if self.log is not None:
            self.log.write(self.options.commands, message)

    def halt(self) -> bool:
        """Write the task's safe action from the latest reading now (and keep it in force). True."""
        with self._lock:
            reading = self._reading
        safe = safe_action(self.task, None if reading is None else reading.state)
        with self._lock:
            self._command = safe
        self._write(safe)
        return True

    def close(self) -> None:
        """Wait briefly for the robot to acknowledge the last command, leave the DDS domain and
        finish the MCAP log. The bridge cannot be used after."""
        from cyclonedds.util import duration

        if self._closed:
            return
        self._closed = True
        try:
            self._writer.wait_for_acks(duration(milliseconds=200))
        except Exception:  # no reader, or the robot gone: nothing to wait for
            pass
        # the robot's record of the last commands, which came after the last reading
        self._log_applied()
        link.close_participant(self._participant)
        if self.log is not None:
            self.log.close()


def _ns(stamp: msg.Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
