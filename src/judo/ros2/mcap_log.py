"""An MCAP log of a robot link, with ROS 2 schemas: Foxglove and `ros2 bag` open it as a ROS 2 bag.

Each message is stored as its CDR bytes (the bytes on the DDS wire), on a channel named by its ROS 2
topic, with the message's ROS 2 definition as the channel's "ros2msg" schema. The log time is the
wall clock of the process that logs (ns since the Unix epoch); the publish time is the message's
header stamp where it has one. A metadata record named "judo" (`METADATA`) says what the bridge
knew: the task, the joint map and the topics (with "applied", the topic of the commands the robot
applied, logged beside those sent); `judo.ros2.mcap_read` reads the log back. Each [safety] limit
hit of the closed loop on the bridge is a judo_msgs/LimitHit (stamp: the plant time, limit, value)
on LIMIT_HITS_TOPIC (`LimitHitLog`).
"""

import threading
import time
from pathlib import Path
from typing import Any

from judo.core.errors import JudoError, import_extra
from judo.core.task import Task
from judo.loop.records import PlanRecord, StepRecord
from judo.ros2.link import APPLIED_SUFFIX
from judo.ros2.messages import MSGDEFS, ROS_NAMES, LimitHit, stamp_of
from judo.ros2.options import Ros2Options

METADATA = "judo"
"""Name of the log's metadata record of judo's own entries ({"task": ..., "joint_map": ...,
topics})."""


class McapLog:
    """Writes ROS 2 messages to the MCAP file at `path` (replaced if it exists); safe to use from
    several threads.

    Call `close()` to finish the file (its summary and index); a log never closed cannot be read
    back whole. `metadata` ({name: text}) is written as the "judo" metadata record.
    """

    def __init__(self, path: str | Path, metadata: dict[str, str] | None = None) -> None:
        writer_module = import_extra("mcap.writer", "an MCAP log (--record)", "ros2")
        self.path = Path(path)
        try:
            self._file = self.path.open("wb")
        except OSError as err:
            raise JudoError(
                f"cannot write the MCAP log {self.path}: {err.strerror or err}"
            ) from err
        self._writer = writer_module.Writer(self._file)
        self._writer.start(profile="ros2", library="judo")
        if metadata:
            self._writer.add_metadata(METADATA, dict(metadata))
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self._lock = threading.Lock()
        self._closed = False
        self.messages = 0
        """Messages written so far."""

    def write(self, topic: str, message: Any, publish_ns: int | None = None) -> None:
        """Log `message` (one of judo.ros2.messages' classes) on the ROS 2 `topic` (e.g.
        "/joint_states")."""
        name = ROS_NAMES[type(message)]
        data = message.serialize()
        now = time.time_ns()
        with self._lock:
            if self._closed:
                return
            channel = self._channels.get(topic)
            if channel is None:
                schema = self._schemas.get(name)
                if schema is None:
                    schema = self._schemas[name] = self._writer.register_schema(
                        name, "ros2msg", MSGDEFS[name].encode()
                    )
                channel = self._channels[topic] = self._writer.register_channel(
                    topic, "cdr", schema
                )
            self._sequence += 1
            self._writer.add_message(
                channel, now, bytes(data), now if publish_ns is None else publish_ns, self._sequence
            )
            self.messages += 1

    def close(self) -> None:
        """Finish the file; later writes are ignored."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._writer.finish()
            self._file.close()


LIMIT_HITS_TOPIC = "/judo/limit_hits"
"""The log's topic of the serve filter's limit hits (judo_msgs/LimitHit: stamp, limit, value)."""


class LimitHitLog:
    """The closed loop's recorder that writes each step's limit hits (`StepRecord.limit_hits`) to
    `log`, one judo_msgs/LimitHit each on LIMIT_HITS_TOPIC, stamped (and published) at the hit's
    plant time."""

    def __init__(self, log: McapLog) -> None:
        self.log = log

    def on_plan(self, record: PlanRecord) -> None:
        """Plans are not logged here."""

    def on_step(self, record: StepRecord) -> None:
        for hit in record.limit_hits:
            stamp = stamp_of(max(0.0, hit.time))
            message = LimitHit(stamp, hit.limit, float(hit.value))
            self.log.write(LIMIT_HITS_TOPIC, message, stamp.sec * 1_000_000_000 + stamp.nanosec)


def log_metadata(task: Task, options: Ros2Options) -> dict[str, str]:
    """The MCAP log's "judo" record: the task's registered name (where one name has its class), the
    joint map ("mjcf=robot" entries, comma-separated) and the topics (the commands sent and
    applied), so that `replay` and `sysid` read the log alone."""
    from judo.core.configuration.registry import get_registered_tasks

    names = [name for name, (cls, _) in get_registered_tasks().items() if cls is type(task)]
    metadata = {"joint_map": ",".join(options.joint_map), "joint_states": options.joint_states}
    metadata.update({"odom": options.odom, "mocap": options.mocap, "commands": options.commands})
    metadata["applied"] = options.commands + APPLIED_SUFFIX
    if len(names) == 1:
        metadata["task"] = names[0]
    return metadata
