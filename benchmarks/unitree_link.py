"""The Unitree bridge across two processes on loopback: its added time per cycle and the round trip
to the robot.

- Per cycle: the bridge's read_state + apply + step (a LowCmd_ built, its CRC, written; the pacing
  sleep off: a rate of 1 MHz), microseconds, median and p99, with its parts: the CRC of one LowCmd_,
  and cyclonedds' serialization of one LowCmd_ and deserialization of one LowState_ (pure Python in
  cyclonedds' wheel).
- Round trip: a LowCmd_ written on rt/lowcmd, read by the robot process (`python -m judo plant
  --protocol unitree --echo`), which writes it straight back on rt/lowcmd_echo; median and p99 of
  write -> echo read, ms (two DDS hops, each with a serialization; one way is about half).

    PYTHONPATH=src python benchmarks/unitree_link.py [--task go2_stand] [--robot go2] [--cycles 1000]

Needs pip install -e ".[unitree]". On a shared, loaded machine every figure is slower and its p99
much more so.
"""  # noqa: E501

import os
import random
import subprocess
import sys
import time
from dataclasses import dataclass

import numpy as np
import tyro

from judo.core.configuration.registry import make_task
from judo.ros2 import link as ros2_link
from judo.ros2.options import UnitreeOptions
from judo.unitree import crc
from judo.unitree import motors as mt
from judo.unitree.bridge import UnitreeSystem
from judo.unitree.link import COMMAND_QOS, Link
from judo.unitree.robot import ECHO


@dataclass
class Options:
    task: str = "go2_stand"
    """A task whose model is the robot's (its actuators Unitree's motors)."""
    robot: str = "go2"
    """go2 or g1."""
    cycles: int = 1000
    """Bridge cycles timed, and round trips."""


def percentiles(values: list[float], scale: float) -> str:
    a = np.asarray(values) * scale
    return f"median {np.median(a):.3g}, p99 {np.percentile(a, 99):.3g}"


def per_part(motors: mt.Motors, repeats: int = 300) -> dict[str, list[float]]:
    """Seconds of each part of a cycle, `repeats` times each."""
    command = mt.low_cmd(motors, np.zeros(motors.count), motors.kp, motors.kd)
    state_bytes = crc.with_crc(motors.robot.low_state()).serialize()
    parts: dict[str, list[float]] = {
        "CRC of a LowCmd_": [],
        "serialize a LowCmd_": [],
        "deserialize a LowState_": [],
    }
    for _ in range(repeats):
        for name, work in (
            ("CRC of a LowCmd_", lambda: crc.with_crc(command)),
            ("serialize a LowCmd_", command.serialize),
            ("deserialize a LowState_", lambda: motors.robot.low_state.deserialize(state_bytes)),
        ):
            start = time.perf_counter()
            work()
            parts[name].append(time.perf_counter() - start)
    return parts


def main(options: Options) -> None:
    domain = random.SystemRandom().randint(100, 232)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(["src", os.environ.get("PYTHONPATH", "")])}
    args = [
        "--task",
        options.task,
        "--protocol",
        "unitree",
        "--unitree.robot",
        options.robot,
        "--echo",
    ]
    robot = subprocess.Popen(
        [sys.executable, "-m", "judo", "plant", *args, "--unitree.domain", str(domain)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    try:
        assert robot.stdout is not None
        print(robot.stdout.readline().strip())
        task = make_task(options.task)
        bridge_options = UnitreeOptions(robot=options.robot, domain=domain, rate_hz=1e6)  # type: ignore[arg-type]
        system = UnitreeSystem(task, bridge_options)
        hold = task.command_range.mean(axis=1)
        cycles = []
        for _ in range(options.cycles):
            start = time.perf_counter()
            system.read_state()
            system.apply(hold)
            system.step()
            cycles.append(time.perf_counter() - start)
        print(f"bridge cycle (read_state + apply + step), us: {percentiles(cycles, 1e6)}")
        for name, seconds in per_part(system.motors).items():
            print(f"  {name}, us: {percentiles(seconds, 1e6)}")
        system.close()
        print(
            f"round trip rt/lowcmd -> robot -> {ECHO}, ms: "
            f"{percentiles(round_trips(options, domain), 1e3)}"
        )
    finally:
        robot.terminate()
        robot.wait(timeout=10)


def round_trips(options: Options, domain: int) -> list[float]:
    """Seconds from writing each of `options.cycles` LowCmd_ to reading the robot's echo of it."""
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    motors = mt.Motors.of(make_task(options.task).model, options.robot)
    kind = motors.robot
    link = Link(domain, None, kind.low_state, kind.low_cmd)
    try:
        writer = DataWriter(link.participant, link.command_topic, COMMAND_QOS)
        echoes = DataReader(
            link.participant, Topic(link.participant, ECHO, kind.low_cmd), COMMAND_QOS
        )
        deadline = time.monotonic() + 10
        while not echoes.get_matched_publications() and time.monotonic() < deadline:
            time.sleep(0.01)
        trips = []
        command = mt.low_cmd(
            motors, np.zeros(motors.count), np.zeros(motors.count), np.full(motors.count, 1.0)
        )
        for i in range(options.cycles):
            command.motor_cmd[0].tau = float(i)  # which command the echo is
            crc.with_crc(command)
            start = time.perf_counter()
            writer.write(command)
            while True:
                got = [c for c in ros2_link.take(echoes, 16) if c.motor_cmd[0].tau == float(i)]
                if got or time.perf_counter() - start > 1.0:
                    break
            if got:
                trips.append(time.perf_counter() - start)
        return trips
    finally:
        link.close()


if __name__ == "__main__":
    main(tyro.cli(Options))
