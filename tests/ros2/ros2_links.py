"""Helpers for real ROS 2 links on loopback: plant processes (`python -m judo plant`) and in-process
DDS robots, each on a DDS domain of its own, so tests never hear each other."""

import dataclasses
import os
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import judo
from judo.core.configuration.registry import make_config
from judo.optimizers.mppi import MPPIConfig

ROOT = Path(__file__).resolve().parents[2]


def free_domain() -> int:
    """A random DDS domain id for one test's link."""
    return random.SystemRandom().randint(100, 232)


def env(domain: int | None = None) -> dict[str, str]:
    """The environment of a judo subprocess: this checkout's src first, on `domain`."""
    extra = {} if domain is None else {"ROS_DOMAIN_ID": str(domain)}
    pythonpath = os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])
    return {**os.environ, "PYTHONPATH": pythonpath, **extra}


def started(args: list[str], ready: str) -> subprocess.Popen:
    """`python ARGS` in the repository with the test's DDS settings, once its first line of output
    holds `ready`."""
    proc = subprocess.Popen(
        [sys.executable, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env(),
        cwd=ROOT,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert ready in line, line
    return proc


def start_plant(domain: int, *flags: str, task: str = "cartpole") -> subprocess.Popen:
    """`python -m judo plant --task TASK` on `domain`, once it says it publishes."""
    return started(
        ["-m", "judo", "plant", "--task", task, "--ros2.domain-id", str(domain), *flags],
        "publishing rt/",
    )


def record_multisine(path, domain: int, steps: int) -> np.ndarray:
    """Drive the cart-pole robot on `domain` through the bridge, recording to `path`, by `steps`
    commands of a multisine at the bridge's 100 Hz; returns them (C, 1)."""
    from judo.ros2.bridge import Ros2System
    from judo.ros2.options import Ros2Options
    from judo.sysid.excite import multisine
    from judo.system_choice import SystemOptions
    from judo.tasks.cartpole import Cartpole

    task = Cartpole()
    options = SystemOptions(system="ros2", record=path, ros2=Ros2Options(domain_id=domain))
    system = Ros2System.from_options(task, options)
    commands = multisine(task.model.actuator_ctrlrange, np.arange(steps) * 0.01, 0.5, 2.0, seed=0)
    try:
        for command in commands:
            system.read_state()
            system.apply(command)
            system.step()
    finally:
        system.close()
    return commands


def stop_process(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


class DdsRobot:
    """A robot written in the test on cyclonedds: publishes the JointStates it is given, and a valid
    one every 10 ms until `stop_streaming` (positions only where `velocity` is False)."""

    def __init__(self, domain: int, velocity: bool = True) -> None:
        from cyclonedds.pub import DataWriter

        from judo.ros2 import link
        from judo.ros2 import messages as msg

        self.msg, self.link = msg, link
        self.participant = link.participant(domain)
        self.writer = DataWriter(
            self.participant,
            link.topic(self.participant, "/joint_states", msg.JointState),
            link.SENSOR_QOS,
        )
        self.stamp = 1.0
        self.velocity = velocity
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._stream, daemon=True)
        self._thread.start()

    def send(
        self, names: list[str], position: list[float], velocity: list[float], stamp: float
    ) -> None:
        msg = self.msg
        self.writer.write(
            msg.JointState(msg.Header(msg.stamp_of(stamp)), names, position, velocity, [])
        )

    def _stream(self) -> None:
        while not self._stop.is_set():
            self.stamp += 0.01
            self.send(
                ["slider", "hinge"], [0.1, 3.0], [0.0, 0.0] if self.velocity else [], self.stamp
            )
            time.sleep(0.01)

    def stop_streaming(self) -> None:
        self._stop.set()
        self._thread.join()

    def close(self) -> None:
        self.stop_streaming()
        self.link.close_participant(self.participant)


def poll(condition: Callable[[], bool], timeout: float = 5.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.005)


def echo_reader(domain: int):
    """A participant and reader of the plant's echo of the commands it read, on `domain`."""
    from cyclonedds.sub import DataReader

    from judo.ros2 import link
    from judo.ros2 import messages as msg

    part = link.participant(domain)
    return part, DataReader(
        part, link.topic(part, "/judo/commands_echo", msg.Float64MultiArray), link.COMMAND_QOS
    )


def echoes(reader) -> list[np.ndarray]:
    from judo.ros2 import link

    return [np.asarray(m.data) for m in link.take(reader, 64)]


def small_controller(**config) -> judo.Controller:
    """cartpole's mppi with few rollouts, so it keeps up on a busy machine; `config` changes
    ControllerConfig fields."""
    controller_config = dataclasses.replace(
        make_config(judo.ControllerConfig, "cartpole"), horizon=0.5, control_freq=20.0, **config
    )
    optimizer_config = dataclasses.replace(make_config(MPPIConfig, "cartpole"), num_rollouts=16)
    return judo.make_controller(
        "cartpole",
        "mppi",
        controller_config=controller_config,
        optimizer_config=optimizer_config,
        seed=0,
        num_workers=1,
    )


PUBLISHER = """
import json, sys, time
from cyclonedds.pub import DataWriter
from judo.ros2 import link, messages as msg
domain, names, states = int(sys.argv[1]), json.loads(sys.argv[2]), json.loads(sys.argv[3])
part = link.participant(domain)
writer = DataWriter(part, link.topic(part, "/joint_states", msg.JointState), link.SENSOR_QOS)
print("publishing", flush=True)
stamp = 1.0
while True:
    for position, velocity in states:
        stamp += 0.01
        writer.write(msg.JointState(msg.Header(msg.stamp_of(stamp)), names, position, velocity, []))
        time.sleep(0.01)
"""


def start_publisher(
    domain: int, names: list[str], states: list[tuple[list[float], list[float]]]
) -> subprocess.Popen:
    """A process of its own that publishes JointStates of `names` on `domain`: each (positions,
    velocities) of `states` in turn, over and over, every 10 ms, stamped 10 ms apart; started once
    it says it publishes."""
    import json

    return started(
        ["-c", PUBLISHER, str(domain), json.dumps(names), json.dumps(states)], "publishing"
    )
