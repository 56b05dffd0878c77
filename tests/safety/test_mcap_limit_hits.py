"""Limit hits in the ROS 2 bridge's MCAP log: one judo_msgs/LimitHit (stamp, limit, value) per hit
of the closed loop on the bridge, over a real DDS link to a robot process (`python -m judo
plant`)."""

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cyclonedds")
pytest.importorskip("mcap_ros2")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "ros2"))
from ros2_links import free_domain, started, stop_process

from judo.core.policies.policy_controller import make_policy_controller
from judo.core.policy import Policy
from judo.loop.closed_loop import ClosedLoop
from judo.ros2 import messages as msg
from judo.ros2.bridge import Ros2System
from judo.ros2.mcap_log import LIMIT_HITS_TOPIC, LimitHitLog, McapLog
from judo.ros2.options import Ros2Options
from judo.safety.config import SafetyConfig
from judo.safety.serve_filter import safety_guard

pytestmark = pytest.mark.slow


class Rogue(Policy):
    """Pushes the cart as hard as it can, always."""

    observation_size, action_size, horizon, metadata = 5, 1, 1, {}

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), 1, 1), 1e9)


def test_each_limit_hit_is_a_record_of_the_bridges_log(tmp_path):
    from mcap.reader import make_reader

    domain = free_domain()
    plant = started(
        ["-m", "judo", "plant", "--task", "cartpole", "--ros2.domain-id", str(domain)], "publishing"
    )
    controller = make_policy_controller("cartpole", Rogue(), seed=0)
    system = Ros2System(
        controller.task, Ros2Options(domain_id=domain), McapLog(tmp_path / "run.mcap")
    )
    try:
        assert isinstance(system.recorder(), LimitHitLog)
        loop = ClosedLoop(
            controller, system, guard=safety_guard(controller, SafetyConfig(effort=("push=0.8",)))
        )
        loop.restart()
        for _ in range(10):
            loop.step()
        assert loop.guard is not None
        counts = dict(loop.guard.counts)
    finally:
        system.close()
        controller.close()
        stop_process(plant)
    assert counts.get("effort:push", 0) > 0, counts
    hits = []
    with (tmp_path / "run.mcap").open("rb") as file:
        reader = make_reader(file)
        for schema, channel, message in reader.iter_messages(topics=[LIMIT_HITS_TOPIC]):
            assert (
                schema is not None
                and schema.name == "judo_msgs/msg/LimitHit"
                and channel.message_encoding == "cdr"
            )
            hit = msg.LimitHit.deserialize(message.data)
            assert message.publish_time == hit.stamp.sec * 1_000_000_000 + hit.stamp.nanosec
            hits.append((msg.seconds_of(hit.stamp), hit.limit, hit.value))
    assert {limit for _, limit, _ in hits} == set(counts) and len(hits) == sum(counts.values())
    # the force it asked for
    assert all(value > 0.8 for _, limit, value in hits if limit == "effort:push")
    assert np.all(np.diff([t for t, _, _ in hits]) >= 0)
