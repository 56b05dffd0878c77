"""A ROS 2 bridge's MCAP log (`--record FILE.mcap`) read back as the arrays that `replay` plays and
`sysid` fits.

    python -m judo replay run.mcap                         # the task named in the log; --task for another log
    python -m judo sysid run.mcap --task cartpole --params body_mass.pole --out fitted.toml

Each message is decoded by `mcap_ros2` from the ROS 2 definition stored beside it in the log (the
bridge stores judo.ros2.messages' own), so reading needs the `ros2` extra's `mcap` and
`mcap-ros2-support`, and no DDS. A `ros2 bag record` MCAP of the same topics reads the same way
(give --task: only the bridge names its task).

- The rows are the sensor_msgs/JointState messages, in stamp order (a repeated or older stamp is
  skipped), at their header stamps: the robot's clock. Each joint is placed in qpos and qvel by
  name, as the bridge maps it (`JointLayout`, with the joint map the log's "judo" metadata record
  holds). A free base comes from the latest nav_msgs/Odometry logged before the row, mocap bodies
  from the latest geometry_msgs/PoseArray.
- The applied commands, where the log holds them, are what the robot reports it applied: the
  JointStates on <commands>_applied (`python -m judo plant` publishes them, the bridge logs them
  when recording), the command in `effort` in actuator order, each stamped with the robot's time at
  the start of the first step it was in force. The action of a row (applied during the plant step
  that ended at it) is then the latest applied command stamped before the row's stamp: exact however
  late each command reached the robot. A log without them (an older bridge's, or a robot that
  reports none) pairs each row with the commands sent, as follows.
- The commands are the std_msgs/Float64MultiArray messages judo wrote. The bridge logs them at its
  wall clock, so each is placed on the robot's clock by the offset between the two that the joint
  states show: the largest (stamp - log time) of those logged in the second before it, the least
  delayed. The robot holds a command until the next: the action of a row, applied during the plant
  step that ended at it, is the latest command at or before its stamp. That is exactly what judo's
  plant process applied (it computes a step when its time comes, with the command it holds then)
  where each command reached it in time; one that came a step late was applied a step late, which
  this pairing cannot see (`sysid` fits a command delay for it).
"""  # noqa: E501

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import import_extra
from judo.ros2.bridge_log import (
    COMMANDS,
    JOINT_STATE,
    ODOMETRY,
    POSES,
    BridgeLog,
    BridgeLogError,
)
from judo.ros2.joints import JointLayout, base_from_odometry

METADATA = "judo"
"""The bridge's metadata record (judo.ros2.mcap_log.METADATA; not imported from there, which needs
DDS)."""
DEFAULT_TOPICS = {
    "joint_states": "/joint_states",
    "commands": "/judo/commands",
    "odom": "/odom",
    "mocap": "/judo/mocap",
}
"""The bridge's default topics, for a log without the "judo" record (the applied commands': the
commands' topic with APPLIED_SUFFIX)."""
APPLIED_SUFFIX = "_applied"
"""judo.ros2.link.APPLIED_SUFFIX (not imported from there, which needs DDS)."""
OFFSET_WINDOW_S = 1.0
"""Wall seconds of joint states before a command whose least delayed one places it on the robot's
clock."""


def read_bridge_log(
    path: Path, task: str | None = None, feature: str = "reading an MCAP log"
) -> BridgeLog:
    """The bridge log at `path` for `task` (None: the task the log names). BridgeLogError, in one
    line naming the file, for a file that is missing, empty or not MCAP, a log of another task, one
    that names no task when `task` is None, one without JointStates, or joints the task's model
    lacks (each listing what the log holds)."""
    from judo.core.configuration.registry import make_task

    reader_module = import_extra("mcap.reader", feature, "ros2")
    decoder_module = import_extra("mcap_ros2.decoder", feature, "ros2")
    path = Path(path)
    if not path.is_file():
        raise BridgeLogError(
            f"{path}: no such log file; give the MCAP file the bridge wrote (--record FILE.mcap)"
        )
    if path.stat().st_size == 0:
        raise BridgeLogError(
            f"{path}: the file is empty; give the MCAP file the bridge wrote (--record FILE.mcap)"
        )
    try:
        with path.open("rb") as file:
            metadata, raw = _read(reader_module, decoder_module, file)
    except Exception as err:  # mcap raises its own errors, struct's and EOF for a corrupt file
        text = " ".join(str(err).split())[:120] or type(err).__name__
        raise BridgeLogError(f"{path}: not a readable MCAP log ({text})") from None
    logged_task = metadata.get("task") or None
    if task is None and logged_task is None:
        raise BridgeLogError(
            f"{path}: the log does not name its task (the bridge's record does); give --task"
        )
    if task is not None and logged_task is not None and task != logged_task:
        raise BridgeLogError(f"{path}: a log of task {logged_task!r}, not of --task {task!r}")
    name = task or logged_task
    assert name is not None
    model = make_task(name).sim_model
    topics = {key: metadata.get(key) or value for key, value in DEFAULT_TOPICS.items()}
    topics["applied"] = metadata.get("applied") or topics["commands"] + APPLIED_SUFFIX
    joint_map = tuple(entry for entry in metadata.get("joint_map", "").split(",") if entry)
    return _arrays(path, name, model, JointLayout.of(model, joint_map), raw, topics)


@dataclass
class _Message:
    log_ns: int
    topic: str
    schema: str
    message: Any


def _read(
    reader_module: Any, decoder_module: Any, file: Any
) -> tuple[dict[str, str], list[_Message]]:
    """(the "judo" metadata record, every message of the four types read, decoded, in log order)."""
    reader = reader_module.make_reader(file)
    wanted = {JOINT_STATE, COMMANDS, ODOMETRY, POSES}
    factory = decoder_module.DecoderFactory()
    decoders: dict[int, Any] = {}
    messages = []
    for schema, channel, message in reader.iter_messages(log_time_order=True):
        name = schema.name if schema is not None else ""
        entry = _Message(message.log_time, channel.topic, name, None)
        if schema is not None and name in wanted:
            decoder = decoders.get(schema.id)
            if decoder is None:
                decoder = decoders[schema.id] = factory.decoder_for(
                    channel.message_encoding, schema
                )
            entry.message = decoder(message.data)
        messages.append(entry)
    file.seek(0)
    metadata = {}
    for record in reader_module.make_reader(file).iter_metadata():
        if record.name == METADATA:
            metadata = dict(record.metadata)
    return metadata, messages


def _seen(raw: list[_Message]) -> str:
    """The topics of `raw` with their types, for an error."""
    topics = sorted({(m.topic, m.schema or "no schema") for m in raw})
    return ", ".join(f"{topic} ({schema})" for topic, schema in topics) or "no messages"


def _arrays(
    path: Path,
    task: str,
    model: mujoco.MjModel,
    layout: JointLayout,
    raw: list[_Message],
    topics: dict[str, str],
) -> BridgeLog:
    joints = [m for m in raw if m.schema == JOINT_STATE and m.topic == topics["joint_states"]]
    if not joints:
        others = sorted({m.topic for m in raw if m.schema == JOINT_STATE})
        raise BridgeLogError(
            f"{path}: no {JOINT_STATE} on {topics['joint_states']}"
            + (f" (there are on {', '.join(others)})" if others else "")
            + f"; the log holds {_seen(raw)}"
        )
    index = {name: i for i, name in enumerate(layout.names)}
    rows: list[tuple[float, int, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]] = []
    odom: tuple[np.ndarray, np.ndarray] | None = None
    mocap: np.ndarray | None = None
    last = -math.inf
    for entry in raw:
        message = entry.message
        if entry.schema == ODOMETRY and entry.topic == topics["odom"]:
            odom = base_from_odometry(message)
        elif (
            entry.schema == POSES
            and entry.topic == topics["mocap"]
            and len(message.poses) == model.nmocap
        ):
            mocap = np.array(
                [[p.position.x, p.position.y, p.position.z] for p in message.poses], float
            ).reshape(-1)
        elif entry.schema == JOINT_STATE and entry.topic == topics["joint_states"]:
            names = list(message.name)
            unknown = [name for name in names if name not in index]
            missing = [name for name in layout.names if name not in set(names)]
            if unknown or missing:
                raise BridgeLogError(
                    f"{path}: its joint states name the joints {names}; {task}'s model has "
                    f"{list(layout.names)} "
                    f"(missing {missing}, unknown {unknown})"
                )
            position = np.asarray(message.position, float)
            velocity = (
                np.asarray(message.velocity, float) if len(message.velocity) == len(names) else None
            )
            if len(position) != len(names):
                continue  # the bridge logs none such; a robot's own log may
            stamp = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
            if stamp <= last + 1e-9 or (layout.free is not None and odom is None):
                continue  # a duplicate or a late message; a free base not known yet
            last = stamp
            order = [index[name] for name in names]
            qpos, qvel = model.qpos0.copy(), np.full(model.nv, np.nan)
            qpos[layout.qpos[order]] = position
            if velocity is not None:
                qvel[layout.qvel[order]] = velocity
            if layout.free is not None and odom is not None:
                a, d = layout.free
                qpos[a : a + 7], qvel[d : d + 6] = odom
            rows.append(
                (stamp, entry.log_ns, qpos, qvel, None if mocap is None else mocap.copy(), None)
            )
    if not rows:
        raise BridgeLogError(
            f"{path}: no joint state came after an {ODOMETRY} on {topics['odom']} for the free base"
        )
    times = np.array([row[0] for row in rows])
    command_times, commands = _commands(path, raw, topics["commands"], rows, model.nu)
    applied_times, applied = _applied(path, raw, topics["applied"], model.nu)
    timestep = float(model.opt.timestep)
    mocaps = [row[4] for row in rows]
    mocap_pos = None
    if model.nmocap and any(m is not None for m in mocaps):
        first = next(m for m in mocaps if m is not None)
        mocap_pos = np.array([first if m is None else m for m in mocaps])
    log = BridgeLog(
        path,
        task,
        times,
        np.array([row[2] for row in rows]),
        np.array([row[3] for row in rows]),
        np.empty((0, model.nu)),
        mocap_pos,
        command_times,
        commands,
        timestep,
        topics,
        applied_times,
        applied,
    )
    log.actions = log.actions_at(times)
    return log


def _applied(path: Path, raw: list[_Message], topic: str, nu: int) -> tuple[np.ndarray, np.ndarray]:
    """((A,) the stamps, (A, nu) the commands) the robot reported applying on `topic` (JointStates,
    each command in `effort`), in stamp order (a command of the same stamp as one before it replaced
    it); both empty without. BridgeLogError for a record of another size than the model's `nu`
    actuators."""
    found = [m.message for m in raw if m.schema == JOINT_STATE and m.topic == topic]
    values = [np.asarray(message.effort, float) for message in found]
    wrong = sorted({len(v) for v in values if len(v) != nu})
    if wrong:
        raise BridgeLogError(
            f"{path}: applied commands on {topic} of {wrong} values; the task's model has "
            f"{nu} actuators"
        )
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in found], float)
    order = np.argsort(stamps, kind="stable")
    return stamps[order], np.array(values, float).reshape(len(found), nu)[order]


def _commands(
    path: Path, raw: list[_Message], topic: str, rows: list[Any], nu: int
) -> tuple[np.ndarray, np.ndarray]:
    """((C,) the commands' times on the robot's clock, (C, nu) the commands) on `topic`."""
    found = [m for m in raw if m.schema == COMMANDS and m.topic == topic]
    values = [np.asarray(m.message.data, float) for m in found]
    wrong = sorted({len(v) for v in values if len(v) != nu})
    if wrong:
        raise BridgeLogError(
            f"{path}: commands on {topic} of {wrong} values; the task's model has {nu} actuators"
        )
    stamps = np.array([row[0] for row in rows])
    logged = 1e-9 * np.array([row[1] for row in rows], float)
    # the robot's clock less the logging wall clock, each message's delay below it
    offsets = stamps - logged
    times = np.empty(len(found))
    for i, message in enumerate(found):
        wall = 1e-9 * message.log_ns
        near = (logged <= wall) & (logged >= wall - OFFSET_WINDOW_S)
        times[i] = wall + (
            offsets[near].max() if near.any() else offsets[np.argmin(np.abs(logged - wall))]
        )
    return times, np.array(values).reshape(len(found), nu)
