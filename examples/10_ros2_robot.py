"""A robot judo drives over ROS 2, written with nothing but cyclonedds, MuJoCo and ROS 2's standard
types.

No judo code runs here: this process stands for a robot's driver. It simulates a cart-pole with
MuJoCo (the hardware), publishes sensor_msgs/JointState on /joint_states at 100 Hz stamped with its
own clock, and applies every std_msgs/Float64MultiArray it reads on /judo/commands to its motor, as
a ros2_control forward command controller would. The types are ROS 2's own DDS
types (`sensor_msgs::msg::dds_::JointState_` on the DDS topic
`rt/joint_states`), so a ROS 2 node on the same ROS_DOMAIN_ID hears it too. Two processes:

    PYTHONPATH=src python examples/10_ros2_robot.py &                     # the robot, hanging down
    PYTHONPATH=src python -m judo --task cartpole --system ros2 --headless --duration 20

judo swings the pole up and balances it; at the end this process prints the fraction of the last 5 s
before judo's last command that the pole spent upright (|angle| < 0.3 rad). Needs pip
install -e ".[ros2]" (cyclonedds' wheel carries the DDS library).
"""

import argparse
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader, InvalidSample
from cyclonedds.topic import Topic
from cyclonedds.util import duration

MODEL = Path(__file__).resolve().parents[1] / "src" / "judo" / "tasks" / "models" / "cartpole.xml"


@dataclass
@final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
@final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
@final
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
@final
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
@final
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
@final
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


def stamp_of(seconds: float) -> Time:
    """The ROS 2 Time of `seconds`: whole nanoseconds first, then split, so 0.9999999999999999 s (a
    hundred 0.01 s steps) is 1 s 0 ns, never 0 s plus a rounded-up billion nanoseconds."""
    sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
    return Time(sec, nanosec)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--seconds",
        type=float,
        default=60.0,
        help="most wall seconds to run (it stops 1 s after the last command)",
    )
    args = parser.parse_args()

    model = mujoco.MjModel.from_xml_path(str(MODEL))
    data = mujoco.MjData(model)
    data.qpos[1] = math.pi  # the pole hangs down
    names = [model.joint(j).name for j in range(model.njnt)]  # "slider", "hinge"

    participant = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    # ROS 2's sensor-data profile
    sensor_qos = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))
    command_qos = Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(1)
    )
    states = DataWriter(participant, Topic(participant, "rt/joint_states", JointState), sensor_qos)
    commands = DataReader(
        participant, Topic(participant, "rt/judo/commands", Float64MultiArray), command_qos
    )
    print(
        f"robot: publishing rt/joint_states {names} on domain {participant.domain_id}", flush=True
    )

    dt, start, steps, upright, last_command = model.opt.timestep, time.monotonic(), 0, [], 0.0
    commanded_at = None  # wall time of the latest command: the robot stops 1 s after judo went away
    while time.monotonic() - start < args.seconds and (
        commanded_at is None or time.monotonic() - commanded_at < 1
    ):
        for command in commands.take(8):
            # a notice that a writer went away, not a command
            if isinstance(command, InvalidSample):
                continue
            if len(command.data) == model.nu and all(math.isfinite(u) for u in command.data):
                data.ctrl[:] = command.data
                last_command, commanded_at = data.time, time.monotonic()
        mujoco.mj_step(model, data)
        steps += 1
        states.write(
            JointState(
                Header(stamp_of(data.time)), names, data.qpos.tolist(), data.qvel.tolist(), []
            )
        )
        angle = math.remainder(data.qpos[1], 2 * math.pi)
        upright.append((data.time, abs(angle) < 0.3))
        time.sleep(max(0.0, start + steps * dt - time.monotonic()))  # real time
    last = [up for t, up in upright if last_command - 5.0 < t <= last_command]
    print(
        f"robot: upright {sum(last) / max(1, len(last)):.2f} of the last 5 s it was commanded",
        flush=True,
    )


if __name__ == "__main__":
    main()
