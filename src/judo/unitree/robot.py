# pyright: reportAttributeAccessIssue=false
# (a message's fields are its IDL dataclass's; cyclonedds types them loosely)
"""`python -m judo plant --task T --protocol unitree`: judo's simulator as a Unitree robot under
low-level control.

    python -m judo plant --task go2_stand --protocol unitree            # then, in another shell:
    python -m judo --task go2_stand --system unitree --headless
    python -m judo plant --task go2_stand --protocol unitree --latency-ms 5 --drop 0.05 --unitree.domain 7

It simulates the task's plant with its actuators made torque motors (gain 1, no bias, ctrlrange =
forcerange), its physics step divided to `PD_HZ` (500 Hz) or faster, and runs the robot's own PD
every physics step from the latest valid LowCmd_: tau = clip(kp (q - q_meas) + kd (dq - dq_meas) +
tau, forcerange). It publishes rt/lowstate (LowState_) at `--unitree.rate-hz`: each motor's q, dq
and tau_est (the torque applied), the IMU (the task's framequat, gyro and accelerometer sensors, [w
x y z]), the Go2's foot forces (its touch sensors, newtons) and the tick (milliseconds of the
simulation's clock), with its CRC. Each LowCmd_ whose CRC is wrong is dropped, as a robot drops it
(counted, logged); one with a non-finite value for a driven motor too. When no valid command has
come for `--unitree.silence-s` seconds (and before the first), the motors get damping. The link
faults (--latency-ms, --jitter-ms, --drop, --duplicate) apply to each outgoing LowState_. With a
free base, its height and tilt (which no LowState_ carries) are logged every second of simulation.
"""  # noqa: E501

import logging
import math
import threading
import time
from collections.abc import Sequence

import mujoco
import numpy as np

from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import override_task_models, parse_override_entries
from judo.core.configuration.registry import lookup_task
from judo.core.errors import ConfigError
from judo.core.task import new_task
from judo.loop.system import MujocoSystem, SimulationDiverged
from judo.loop.timing import PlantClock
from judo.ros2 import link as ros2_link
from judo.ros2.plant import PROG, Outbox, PlantOptions, check
from judo.ros2.plant import main as ros2_plant_main
from judo.unitree import crc
from judo.unitree import motors as mt
from judo.unitree.link import COMMAND_QOS, STATE_QOS, Link
from judo.unitree.messages import LOWCMD, LOWSTATE

logger = logging.getLogger("judo.unitree.robot")
PD_HZ = 500.0
"""Least rate (Hz) the robot's PD runs at: the plant's physics step is the model's, divided to reach
it."""
REPORT_EVERY = 1.0
"""Seconds of the simulation between log lines of the base's height and tilt (a robot with a free
base)."""
ECHO = LOWCMD + "_echo"
"""With --echo, each LowCmd_ read is written back at once on this topic
(benchmarks/unitree_link.py's round trip)."""


def torque_motors(model: mujoco.MjModel) -> None:
    """Make every actuator of `model` a torque motor in place: ctrl is the joint torque, within its
    forcerange."""
    model.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    model.actuator_gainprm[:] = 0.0
    model.actuator_gainprm[:, 0] = 1.0
    model.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    model.actuator_biasprm[:] = 0.0
    model.actuator_ctrlrange[:] = model.actuator_forcerange
    model.actuator_ctrllimited[:] = 1


def robot_pd(targets: np.ndarray, q: np.ndarray, dq: np.ndarray, motors: mt.Motors) -> np.ndarray:
    """(nu,) the torques the robot's PD gives its motors from (5, nu) `targets` [q, dq, tau, kp, kd]
    at (nu,) `q`, `dq`, within their torque limits."""
    q_des, dq_des, tau, kp, kd = targets
    return np.clip(kp * (q_des - q) + kd * (dq_des - dq) + tau, motors.force_low, motors.force_high)


def run_robot(options: PlantOptions, stop: threading.Event) -> None:
    """Run the robot until `stop` is set (or `options.duration` wall seconds have passed)."""
    from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    check(options)
    unitree = options.unitree
    for name in ("rate_hz", "silence_s"):
        value = getattr(unitree, name)
        if not (math.isfinite(value) and value > 0):
            raise ConfigError(
                f"--unitree.{name.replace('_', '-')} must be a positive number, got {value}"
            )
    task = new_task(lookup_task(options.task)[0])
    if options.plant_overrides:
        overrides = check_model_overrides(
            task.sim_model, parse_override_entries(options.plant_overrides)
        )
        task = override_task_models(task, {}, overrides)
    system = MujocoSystem.from_task(task, options.seed)
    model, data = system.task.sim_model, system.task.data
    # the gains are read before the actuators become motors
    motors = mt.Motors.of(model, unitree.robot)
    torque_motors(model)
    model.opt.timestep /= math.ceil(model.opt.timestep * PD_HZ - 1e-9)  # the PD at PD_HZ or faster
    system.timestep = float(model.opt.timestep)
    sensors = (
        mt.Sensors.of(model, system.task.sim_measured, motors)
        if system.task.sim_measured.size
        else None
    )
    robot = motors.robot
    link = Link(unitree.domain, unitree.interface, robot.low_state, robot.low_cmd)
    part = link.participant
    writer = DataWriter(part, link.state_topic, STATE_QOS)
    reader = DataReader(part, link.command_topic, COMMAND_QOS)
    echo = DataWriter(part, Topic(part, ECHO, robot.low_cmd), COMMAND_QOS) if options.echo else None
    waitset = WaitSet(part)  # wakes the loop when a command arrives
    waitset.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
    outbox = Outbox(
        options, np.random.default_rng(None if options.seed is None else [options.seed, 1])
    )
    damping = np.zeros((5, motors.count))
    damping[4] = mt.DAMPING_KD
    targets, last_command = damping, -math.inf
    dt, period = system.timestep, 1.0 / unitree.rate_hz
    print(
        f"{PROG}: {options.task} as a Unitree {robot.name} on DDS domain {link.domain}, "
        f"publishing {LOWSTATE} at "
        f"{unitree.rate_hz:g} Hz, reading {LOWCMD}",
        flush=True,
    )
    bad_crc = refused = 0
    start = time.monotonic()
    clock = PlantClock()
    next_publish, next_report, tau = 0.0, 0.0, np.zeros(motors.count)
    # the free joint's qpos address
    base = motors.joints.free[0] if motors.joints.free is not None else None
    try:
        while not stop.is_set():
            now = time.monotonic()
            if options.duration is not None and now - start >= options.duration:
                break
            for command in ros2_link.take(reader, 16):
                if echo is not None:
                    echo.write(command)
                if not crc.crc_ok(command):
                    bad_crc += 1
                    logger.warning("dropped command with a wrong CRC (%d so far)", bad_crc)
                    continue
                values = mt.targets_of(command, motors)
                if not np.isfinite(values).all():
                    refused += 1
                    logger.warning("refused command %d: non-finite targets or gains", refused)
                    continue
                targets, last_command = values, now
            live = targets if now - last_command <= unitree.silence_s else damping
            due = clock.due(now, dt)
            for _ in range(due):
                tau = robot_pd(live, data.qpos[motors.qpos], data.qvel[motors.qvel], motors)
                system.apply(tau)
                try:
                    system.step()
                except SimulationDiverged as err:
                    logger.warning("%s", err)
            clock.stepped(due)
            if base is not None and data.time >= next_report:
                next_report = data.time + REPORT_EVERY
                report_base(data, base)
            if due and data.time >= next_publish - 1e-9:
                next_publish = max(next_publish + period, data.time)
                values = system.sensor_values() if sensors is not None else None
                state = lowstate(motors, sensors, data, tau, values)
                outbox.send(writer, crc.with_crc(state), now)
            outbox.flush(time.monotonic())
            later = time.monotonic()
            wait = min(later + clock.wait(later, dt), outbox.next_due(), now + 0.05) - later
            if wait > 0:
                waitset.wait(duration(nanoseconds=int(wait * 1e9)))
    finally:
        link.close()


def report_base(data: mujoco.MjData, address: int) -> None:
    """Log the free base's height, tilt from vertical, position on the floor and heading (its qpos
    at `address`): what no rt/lowstate carries."""
    w, x, y, z = data.qpos[address + 3 : address + 7]
    up = 1.0 - 2.0 * (x * x + y * y)  # the base's z axis against the world's
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, up))))
    yaw = math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    px, py, pz = data.qpos[address : address + 3]
    logger.info(
        "t=%.1f s: base at height %.3f m, tilted %.0f deg, at x %.3f y %.3f m, heading %.1f deg",
        *(data.time, pz, tilt, px, py, yaw),
    )


def lowstate(
    motors: mt.Motors, sensors: mt.Sensors | None, data: mujoco.MjData, tau: np.ndarray, values
):
    """The LowState_ of the plant's `data` (its CRC not yet set): each motor's q, dq, the (nu,)
    torques `tau` applied, and the IMU and foot forces out of the measured sensors' (size,) `values`
    (None: none measured)."""
    message = motors.robot.low_state()
    q, dq = data.qpos[motors.qpos], data.qvel[motors.qvel]
    for i, slot in enumerate(motors.slot.tolist()):
        state = message.motor_state[slot]
        state.mode, state.q, state.dq, state.tau_est = (
            mt.ENABLE,
            float(q[i]),
            float(dq[i]),
            float(tau[i]),
        )
    if sensors is not None:
        imu, feet = sensors.imu_and_feet(values)
        message.imu_state.quaternion = imu["quat"].tolist()
        message.imu_state.gyroscope = imu["gyro"].tolist()
        message.imu_state.accelerometer = imu["acc"].tolist()
        if hasattr(message, "foot_force"):
            message.foot_force = np.clip(np.round(feet), -32768, 32767).astype(int).tolist()
    message.tick = int(round(data.time * 1000)) & 0xFFFFFFFF
    return message


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m judo plant`: judo.ros2.plant's command, with this module's robot for `--protocol
    unitree`."""
    return ros2_plant_main(argv, {"unitree": run_robot})
