"""`python -m judo plant --task T`: judo's simulator as a robot process on a ROS 2 graph.

    python -m judo plant --task cartpole                                  # then, in another shell:
    python -m judo --task cartpole --system ros2 --headless
    python -m judo plant --task cartpole --latency-ms 20 --jitter-ms 10 --drop 0.1 --ros2.domain-id 7

It steps the task's simulated plant in wall time, publishes its joint states (and, for a task with a
free joint, odometry and IMU) at --rate-hz stamped with its own clock (the simulation's time), and
applies each Float64MultiArray it reads on /judo/commands in actuator order, as a ros2_control
forward command controller does. A command of the wrong length or with a non-finite value is refused
and logged. Each command that takes effect is published once on <commands>_applied
(/judo/commands_applied), reliable: a sensor_msgs/JointState named by the actuators with the command
as applied (clamped) in `effort`, stamped with the plant's time at the start of the first step it
was in force, so a log pairs each step with the command the plant applied however late it came
(`judo.ros2.mcap_read`); a command replaced before any step ran under it is not. The faults delay
(--latency-ms, plus up to --jitter-ms at random, which reorders), drop (--drop) and duplicate
(--duplicate) each outgoing reading (not the applied commands: a stamped record, read after the
fact). Another writer of its commands, or another publisher of its joint states (a second plant on
the domain), is warned of.
"""  # noqa: E501

import heapq
import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

import mujoco
import numpy as np
import tyro

from judo.core.configuration.config import check_seed
from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import override_task_models, parse_override_entries
from judo.core.configuration.registry import get_registered_tasks, lookup_task
from judo.core.errors import ConfigError, JudoError, import_extra
from judo.core.task import new_task
from judo.loop.system import MujocoSystem, SimulationDiverged
from judo.loop.timing import PlantClock
from judo.ros2.options import Ros2Options, UnitreeOptions

PROG = "python -m judo plant"
DESCRIPTION = (
    "judo's simulator as a robot process on a ROS 2 graph (DDS, no ROS install), with link faults."
)
logger = logging.getLogger("judo.ros2.plant")

MAX_FAULT_MS = 10_000.0
"""Most milliseconds of --latency-ms or --jitter-ms: a link slower than 10 s is a dead one."""
MAX_RATE_HZ = 10_000.0
"""Most readings a second --rate-hz asks for (the plant publishes at most once a physics step in any
case)."""
MAX_DURATION_S = 7 * 24 * 3600.0
"""Most wall seconds of --duration (a week)."""


@dataclass
class PlantOptions:
    """judo's simulated plant as a robot process speaking ROS 2 over DDS."""

    task: str = "cartpole"
    """Registered task whose simulated plant runs."""
    seed: int | None = 0
    """Seed of the plant's randomised start state."""
    rate_hz: float = 100.0
    """Joint states (and odometry, IMU) published per second."""
    latency_ms: float = 0.0
    """Delay of every outgoing message, in milliseconds."""
    jitter_ms: float = 0.0
    """Up to this much more delay, uniform at random per message (messages then arrive out of
    order)."""
    drop: float = 0.0
    """Fraction of outgoing messages dropped, 0..1."""
    duplicate: float = 0.0
    """Fraction of outgoing messages sent twice, 0..1."""
    duration: float | None = None
    """Stop after this many wall seconds; by default run until Ctrl-C or SIGTERM."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant, by element name, e.g. body_mass.pole=0.13: a robot
    unlike the planning model, to rehearse `python -m judo sysid` on its logs."""
    echo: bool = False
    """Write every command read back on <commands>_echo at once (benchmarks/ros2_bridge.py times the
    round trip)."""
    ros2: Annotated[Ros2Options, tyro.conf.arg(name="ros2")] = field(default_factory=Ros2Options)
    protocol: Literal["ros2", "unitree"] = "ros2"
    """ros2 (this module) or unitree: a Unitree robot under low-level control, rt/lowstate out and
    rt/lowcmd in through the robot's own PD (judo.unitree.robot; --unitree.*)."""
    unitree: Annotated[UnitreeOptions, tyro.conf.arg(name="unitree")] = field(
        default_factory=UnitreeOptions
    )


class Outbox:
    """Outgoing messages held for the link's faults: each is delayed, dropped or duplicated at
    random."""

    def __init__(self, options: PlantOptions, rng: np.random.Generator) -> None:
        self.options, self.rng = options, rng
        self._queue: list[tuple[float, int, Any, object]] = []  # (due, order, DataWriter, message)
        self._count = 0

    def send(self, writer, message, now: float) -> None:
        o = self.options
        if o.drop > 0 and self.rng.random() < o.drop:
            return
        copies = 2 if o.duplicate > 0 and self.rng.random() < o.duplicate else 1
        for _ in range(copies):
            delay = 1e-3 * (
                o.latency_ms + (self.rng.uniform(0, o.jitter_ms) if o.jitter_ms > 0 else 0.0)
            )
            if delay <= 0:
                writer.write(message)
                continue
            self._count += 1
            heapq.heappush(self._queue, (now + delay, self._count, writer, message))

    def next_due(self) -> float:
        """Monotonic time the next held message is due (inf when none is held)."""
        return self._queue[0][0] if self._queue else math.inf

    def flush(self, now: float) -> None:
        """Write every held message whose time has come."""
        while self._queue and self._queue[0][0] <= now:
            _, _, writer, message = heapq.heappop(self._queue)
            writer.write(message)


def check(options: PlantOptions) -> None:
    """ConfigError for a seed, fault, rate or duration out of range."""
    try:
        check_seed(options.seed)
    except ConfigError as err:
        raise ConfigError(f"--{err}") from None
    for name in ("drop", "duplicate"):
        value = getattr(options, name)
        if not 0 <= value <= 1:
            raise ConfigError(f"--{name} must be a fraction 0..1, got {value}")
    for name in ("latency_ms", "jitter_ms"):
        value = getattr(options, name)
        if not (math.isfinite(value) and 0 <= value <= MAX_FAULT_MS):
            raise ConfigError(
                f"--{name.replace('_', '-')} must be from 0 to {MAX_FAULT_MS:g} ms, got {value}"
            )
    if not (math.isfinite(options.rate_hz) and 0 < options.rate_hz <= MAX_RATE_HZ):
        raise ConfigError(
            f"--rate-hz must be above 0 and at most {MAX_RATE_HZ:g} Hz, got {options.rate_hz}"
        )
    if options.duration is not None and not 0 < options.duration <= MAX_DURATION_S:
        raise ConfigError(
            f"--duration must be in (0, {MAX_DURATION_S:g}] s (a week), got {options.duration}"
        )


Runner = Callable[[PlantOptions, threading.Event], None]
"""Runs a robot process of one protocol until the event is set (`run_plant` for ros2)."""


def run_plant(
    options: PlantOptions, stop: threading.Event, protocols: Mapping[str, Runner] | None = None
) -> None:
    """Run the plant until `stop` is set (or `options.duration` wall seconds have passed); a
    protocol other than ros2 by its runner in `protocols` (judo.unitree.robot.main passes unitree's:
    judo.unitree sits above judo.ros2)."""
    from cyclonedds.core import (
        InstanceState,
        Policy,
        Qos,
        ReadCondition,
        SampleState,
        ViewState,
        WaitSet,
    )
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.util import duration

    from judo.ros2 import link
    from judo.ros2 import messages as msg
    from judo.ros2.joints import JointLayout

    if options.protocol != "ros2":
        runner = (protocols or {}).get(options.protocol)
        if runner is None:
            raise ConfigError(
                f"--protocol {options.protocol} runs from `python -m judo plant` "
                "(judo.unitree.robot.main)"
            )
        return runner(options, stop)
    check(options)
    task = new_task(lookup_task(options.task)[0])
    if options.plant_overrides:
        overrides = check_model_overrides(
            task.sim_model, parse_override_entries(options.plant_overrides)
        )
        task = override_task_models(task, {}, overrides)
    system = MujocoSystem.from_task(task, options.seed)
    model, data = system.task.sim_model, system.task.data
    layout = JointLayout.of(model, options.ros2.joint_map)
    domain = link.domain_id(options.ros2.domain_id)
    part = link.participant(domain)
    joints_topic = link.topic(part, options.ros2.joint_states, msg.JointState)
    writers: dict[str, Any] = {"joints": DataWriter(part, joints_topic, link.SENSOR_QOS)}
    # publishers of other processes
    others = Qos(Policy.Reliability.BestEffort, Policy.IgnoreLocal.Participant)
    other_robots = DataReader(part, joints_topic, others)
    if layout.free is not None:
        writers["odom"] = DataWriter(
            part, link.topic(part, options.ros2.odom, msg.Odometry), link.SENSOR_QOS
        )
        writers["imu"] = DataWriter(
            part, link.topic(part, options.ros2.imu, msg.Imu), link.SENSOR_QOS
        )
    # goals and targets the planner reads, as in-process from the reading's metadata
    if model.nmocap:
        writers["mocap"] = DataWriter(
            part, link.topic(part, options.ros2.mocap, msg.PoseArray), link.SENSOR_QOS
        )
    reader = DataReader(
        part, link.topic(part, options.ros2.commands, msg.Float64MultiArray), link.COMMAND_QOS
    )
    echo = None
    if options.echo:
        echo_topic = link.topic(part, options.ros2.commands + "_echo", msg.Float64MultiArray)
        echo = DataWriter(part, echo_topic, link.COMMAND_QOS)
    applied_topic = link.topic(part, options.ros2.commands + link.APPLIED_SUFFIX, msg.JointState)
    # no reader (no bridge recording): nearly free
    applied = DataWriter(part, applied_topic, link.APPLIED_QOS)
    actuators = [model.actuator(i).name or f"actuator{i}" for i in range(model.nu)]
    # the command applied since the last step, published when a step runs under it
    pending: np.ndarray | None = None
    # wakes the loop when a command arrives, so it is read at once, not at the next tick
    waitset = WaitSet(part)
    waitset.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
    outbox = Outbox(
        options, np.random.default_rng(None if options.seed is None else [options.seed, 1])
    )
    size, (low, high) = system.task.command_size, system.task.command_range.T
    dt, period = system.timestep, 1.0 / options.rate_hz
    print(
        f"{PROG}: {options.task} on DDS domain {domain}, publishing "
        f"{msg.ros_topic(options.ros2.joint_states)} at "
        f"{options.rate_hz:g} Hz, reading {msg.ros_topic(options.ros2.commands)}",
        flush=True,
    )
    refused = writers_seen = robots_seen = 0
    start = time.monotonic()
    clock = PlantClock()  # one step per timestep of wall clock, as the app paces its plant
    next_publish = next_check = 0.0
    while not stop.is_set():
        now = time.monotonic()
        if options.duration is not None and now - start >= options.duration:
            break
        for command in link.take(reader, 16):
            values = np.asarray(command.data, float)
            if echo is not None:
                echo.write(command)
            if values.shape != (size,) or not np.isfinite(values).all():
                refused += 1
                logger.warning(
                    "refused command %d: expected %d finite values, got %s",
                    refused,
                    size,
                    values.tolist(),
                )
                continue
            pending = np.clip(values, low, high)
            system.apply(pending)
        due = clock.due(now, dt)  # paused or starved: it falls behind rather than race
        if due and pending is not None:
            applied.write(link.applied(actuators, pending, float(data.time)))
            pending = None
        for _ in range(due):
            try:
                system.step()
            except SimulationDiverged as err:
                logger.warning("%s", err)
        clock.stepped(due)
        if data.time >= next_publish - 1e-9:
            next_publish = max(next_publish + period, data.time)
            qpos, qvel, stamp = data.qpos.copy(), data.qvel.copy(), float(data.time)
            # before the joints, so the reading they make carries the goal they were taken with
            if model.nmocap:
                outbox.send(
                    writers["mocap"], link.mocap_poses(data.mocap_pos, data.mocap_quat, stamp), now
                )
            outbox.send(writers["joints"], link.joint_state(layout, qpos, qvel, stamp), now)
            if layout.free is not None:
                outbox.send(writers["odom"], link.odometry(layout, qpos, qvel, stamp), now)
                outbox.send(
                    writers["imu"],
                    link.imu(qpos, qvel, _body_accel(model, data, layout), layout, stamp),
                    now,
                )
        outbox.flush(time.monotonic())
        if now >= next_check:
            next_check = now + 1.0
            count = len(reader.get_matched_publications())
            if count > 1 and count != writers_seen:
                logger.warning(
                    "%d writers command this robot on %s",
                    count,
                    msg.ros_topic(options.ros2.commands),
                )
            writers_seen = count
            robots = len(other_robots.get_matched_publications())
            if robots > robots_seen:
                logger.warning(
                    "%d other publisher(s) write %s on domain %d: a second robot or plant "
                    "mixes its readings with this "
                    "one's",
                    robots,
                    msg.ros_topic(options.ros2.joint_states),
                    domain,
                )
            robots_seen = robots
        later = time.monotonic()
        # 50 ms: see a stop
        wait = min(later + clock.wait(later, dt), outbox.next_due(), now + 0.05) - later
        if wait > 0:
            waitset.wait(duration(nanoseconds=int(wait * 1e9)))


def _body_accel(model: mujoco.MjModel, data: mujoco.MjData, layout) -> np.ndarray:
    """(3,) what an accelerometer on the base reads: its linear acceleration less gravity, in the
    body frame."""
    a, d = layout.free
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, data.qpos[a + 3 : a + 7])
    return rot.reshape(3, 3).T @ (data.qacc[d : d + 3] - model.opt.gravity)


def main(argv: Sequence[str] | None = None, protocols: Mapping[str, Runner] | None = None) -> int:
    """`python -m judo plant`: parse `argv`, run the plant until stopped, return the exit status.
    `protocols`: the runners of the protocols beyond ros2 (`run_plant`)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    options = tyro.cli(PlantOptions, args=argv, prog=PROG, description=DESCRIPTION)
    if options.task not in get_registered_tasks():
        print(
            f"{PROG}: unknown task {options.task!r}; valid tasks are: "
            f"{', '.join(sorted(get_registered_tasks()))}",
            file=sys.stderr,
        )
        return 2
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    stop = threading.Event()
    saved = {
        sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        import_extra("cyclonedds", PROG, "ros2")
        run_plant(options, stop, protocols)
    except JudoError as err:
        print(f"{PROG}: {err}", file=sys.stderr)
        return 2
    finally:  # a caller's own handlers again (a test, a script that runs the plant in-process)
        for sig, handler in saved.items():
            signal.signal(sig, handler)
    return 0
