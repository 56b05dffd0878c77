"""The other processes on the bridge's topics, counted by DDS discovery: a second writer of the
commands (another judo, a teleop node) would fight over the robot, and a second publisher of the
joint states (a second robot or plant process on the domain) would mix two robots' readings.

Both are refused when the bridge starts, and warned of while it runs (once when their number grows).
"""

import logging
import time

from judo.core.errors import JudoError
from judo.ros2 import messages as msg

logger = logging.getLogger("judo.ros2")

DISCOVERY_S = 0.3
"""Seconds the bridge gives discovery, after the robot's first reading, to find another process on
its topics."""
CHECK_EVERY = 1.0
"""Wall seconds between counts of the other processes on the bridge's topics while it runs."""


class Peers:
    """Counts the other writers of the commands topic and the publishers of the joint states topic.

    Args:
        commands: a reader of the commands topic that ignores the bridge's own participant, so what
            it matches are other processes' writers.
        joints: the bridge's reader of the joint states; it matches every publisher, the robot among
            them.
        topics: (commands topic, joint states topic), as ROS 2 names them.
        domain: the DDS domain, for messages.
    """

    def __init__(self, commands, joints, topics: tuple[str, str], domain: int) -> None:
        self._commands, self._joints = commands, joints
        self.topics, self.domain = topics, domain
        self._next_check = 0.0
        # (other command writers, joint state publishers) last warned of, or fine
        self._warned = (0, 1)

    def command_writers(self) -> int:
        """How many writers of other processes the commands topic has."""
        return len(self._commands.get_matched_publications())

    def joint_publishers(self) -> int:
        """How many publishers the joint states topic has (1: the robot alone)."""
        return len(self._joints.get_matched_publications())

    def refuse_at_start(self, seconds: float = DISCOVERY_S) -> None:
        """Wait up to `seconds` for discovery to find another commander; JudoError when there is
        one, or when the joint states come from more than one publisher."""
        deadline = time.monotonic() + seconds
        while not self.command_writers() and time.monotonic() < deadline:
            time.sleep(0.02)
        commands, joints = (msg.ros_topic(topic) for topic in self.topics)
        if self.command_writers():
            raise JudoError(
                "another participant (a judo, a teleop node) already writes commands on "
                f"{commands} in DDS domain "
                f"{self.domain}: two controllers would fight over the robot; stop it, or use "
                "another "
                "--ros2.commands topic or --ros2.domain-id"
            )
        if (publishers := self.joint_publishers()) > 1:
            raise JudoError(
                f"{publishers} publishers write {joints} in DDS domain {self.domain}, "
                "expected 1 (the robot): a second "
                "robot or plant process would mix its readings with the robot's; stop it, or "
                "use another "
                "--ros2.joint-states topic or --ros2.domain-id"
            )

    def check(self, now: float) -> None:
        """Count the other processes (at most every `CHECK_EVERY` seconds of `now`, monotonic) and
        warn once when their number grows."""
        if now < self._next_check:
            return
        self._next_check = now + CHECK_EVERY
        counts = (self.command_writers(), self.joint_publishers())
        commands, joints = (msg.ros_topic(topic) for topic in self.topics)
        if counts[0] > self._warned[0]:
            logger.warning(
                "%d other writer(s) command %s in domain %d: the robot hears more than one "
                "controller",
                counts[0],
                commands,
                self.domain,
            )
        if counts[1] > self._warned[1]:
            logger.warning(
                "%d publishers write %s in domain %d, expected 1: readings from a second "
                "robot or plant mix in",
                counts[1],
                joints,
                self.domain,
            )
        self._warned = (counts[0], max(1, counts[1]))
