"""Helpers for real Unitree links on loopback: robot processes (`python -m judo plant --protocol
unitree`) on the test leg (leg_task.py) or a registered task, and test-side DDS readers and writers
of rt/lowstate and rt/lowcmd, each on a DDS domain of its own (`free_domain`, from the ROS 2 tests'
helpers)."""

import sys
import threading
import time
from pathlib import Path

import numpy as np
from ros2_links import (  # noqa: F401 (re-exported for the tests)
    free_domain,
    poll,
    started,
    stop_process,
)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import leg_task  # noqa: E402

from judo.unitree import crc  # noqa: E402
from judo.unitree import messages as msg  # noqa: E402
from judo.unitree.link import COMMAND_QOS, STATE_QOS, Link  # noqa: E402

READY = "publishing rt/lowstate"


def start_robot(domain: int, *flags: str, task: str = "unitree_leg"):
    """The robot process of `task` (the test leg by default) on `domain`, once it says it
    publishes."""
    command = [str(HERE / "leg_task.py")] if task == "unitree_leg" else ["-m", "judo"]
    args = [
        *command,
        "plant",
        "--task",
        task,
        "--protocol",
        "unitree",
        "--unitree.domain",
        str(domain),
        *flags,
    ]
    return started(args, READY)


def leg_options(domain: int, **changes):
    from judo.ros2.options import UnitreeOptions

    return UnitreeOptions(domain=domain, **{"soft_start_s": 0.3, "silence_s": 0.5, **changes})


class Wire:
    """A test's own participant on `domain`: reads every rt/lowcmd and rt/lowstate, writes
    rt/lowstate, and rt/lowcmd too where `commands` (another commander, which the bridge refuses at
    start)."""

    def __init__(self, domain: int, commands: bool = False, interface: str | None = None) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader

        self.link = Link(domain, interface, msg.GoLowState, msg.GoLowCmd)
        keep_all = Qos(Policy.Reliability.Reliable(0), Policy.History.KeepLast(4096))
        self.commands = DataReader(self.link.participant, self.link.command_topic, keep_all)
        self.states = DataReader(self.link.participant, self.link.state_topic, STATE_QOS)
        self.command_writer = (
            DataWriter(self.link.participant, self.link.command_topic, COMMAND_QOS)
            if commands
            else None
        )
        self.state_writer = DataWriter(self.link.participant, self.link.state_topic, STATE_QOS)

    def taken_commands(self) -> list:
        from judo.ros2 import link

        return link.take(self.commands, 4096)

    def latest_state(self, timeout: float = 10.0):
        from judo.ros2 import link

        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            states = link.take(self.states, 64)
            if states:
                return states[-1]
            time.sleep(0.01)
        raise AssertionError(f"no rt/lowstate within {timeout} s")

    def close(self) -> None:
        self.link.close()


def leg_state(q, tick: int, dq=(0.0, 0.0, 0.0), quaternion=(1.0, 0.0, 0.0, 0.0)):
    """A Go2 LowState_ of the test leg's three motors (slots 0-2) at `q`, `dq`, with its CRC."""
    state = msg.GoLowState()
    for i in range(3):
        state.motor_state[i].q, state.motor_state[i].dq = float(q[i]), float(dq[i])
    state.imu_state.quaternion = list(quaternion)
    state.imu_state.accelerometer = [0.0, 0.0, 9.81]
    state.tick = tick
    return crc.with_crc(state)


class Streamer:
    """Writes the test leg's LowState_ at `leg_task.STAND` every 5 ms, its tick 5 ms on each time,
    until told to send `bad` (a function of the tick that makes the message) instead, or to stop."""

    def __init__(self, wire: Wire) -> None:
        self.wire, self.tick = wire, 1000
        self.make = lambda tick: leg_state(leg_task.STAND, tick)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.tick += 5
            self.wire.state_writer.write(self.make(self.tick))
            time.sleep(0.005)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def stiff(command, slots=(0, 1, 2)) -> bool:
    """Whether a LowCmd_ drives any of `slots` with a position gain."""
    return any(command.motor_cmd[s].kp > 0 for s in slots)


def drive(system, action: np.ndarray, seconds: float) -> None:
    """Step `system` under `action` for `seconds` of wall time."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        system.read_state()
        system.apply(action)
        system.step()
