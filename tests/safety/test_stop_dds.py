"""The latched stop over a real DDS link: a std_msgs/Bool on /judo/estop, written by this test's
process, latches the stop of `python -m judo --system ros2` (another process), whose commands to the
robot process (`python -m judo plant`) become the safe action until a false clears it."""

import signal
import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from test_stop_process import Judo

from judo.ros2 import link
from judo.ros2 import messages as msg
from judo.ros2.bridge import ESTOP_TOPIC

pytestmark = pytest.mark.slow


def free_domain() -> int:
    import random

    return random.SystemRandom().randint(100, 232)


def wait_until(condition, timeout: float = 120.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.005)


class Applied:
    """The commands the robot process reports applying (<commands>_applied, reliable), taken as they
    come."""

    def __init__(self, reader) -> None:
        self.reader = reader
        self.values: list[np.ndarray] = []

    def take(self) -> list[np.ndarray]:
        new = [np.asarray(m.effort, float) for m in link.take(self.reader, 256)]
        self.values += new
        return new


def test_a_bool_on_judo_estop_latches_the_bridge_until_a_false_clears_it(tmp_path):
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader

    domain, stop_file = free_domain(), tmp_path / "stop.json"
    plant = Judo(
        ["plant", "--task", "cartpole", "--ros2.domain-id", str(domain), "--seed", "0"], stop_file
    )
    app = None
    part = link.participant(domain)
    try:
        plant.wait_for("publishing rt/joint_states")
        reader = DataReader(
            part,
            link.topic(part, "/judo/commands" + link.APPLIED_SUFFIX, msg.JointState),
            link.APPLIED_QOS,
        )
        applied = Applied(reader)
        writer = DataWriter(part, link.topic(part, ESTOP_TOPIC, msg.Bool), link.APPLIED_QOS)
        args = [
            "--task",
            "cartpole",
            "--system",
            "ros2",
            "--headless",
            "--ros2.domain-id",
            str(domain),
            "--seed",
            "0",
        ]
        app = Judo(args, stop_file)
        app.wait_for("running cartpole with mppi")
        wait_until(
            lambda: any(np.any(v != 0) for v in applied.take()),
            what="the plan's commands at the robot",
        )
        wait_until(
            lambda: len(writer.get_matched_subscriptions()) >= 1,
            what="the bridge's /judo/estop reader",
        )

        writer.write(msg.Bool(True))
        sent = time.monotonic()
        wait_until(
            lambda: any(np.all(v == 0) for v in applied.take()), what="the safe action at the robot"
        )
        print(
            "/judo/estop true -> the robot applies the safe action: "
            f"{time.monotonic() - sent:.3f} s"
        )
        app.wait_for("stop latched by /judo/estop")
        app.wait_for("stop in effect after")
        assert stop_file.exists()
        applied.take()  # what was sent before the latch took effect
        count = len(applied.values)
        wait_until(
            lambda: applied.take() is not None and len(applied.values) >= count + 50,
            what="50 more commands",
        )
        later = np.array(applied.values[count:])
        assert np.all(later == 0.0), (
            "cartpole's safe action is 0: every command after the latch took effect"
        )

        writer.write(msg.Bool(False))
        app.wait_for("stop cleared by /judo/estop")
        wait_until(
            lambda: any(np.any(v != 0) for v in applied.take()), what="the plan's commands again"
        )
        assert not stop_file.exists()
        app.proc.send_signal(signal.SIGINT)
        output = app.finish()
        assert (
            "stop: latched by /judo/estop at" in output
            and "stop: cleared by /judo/estop at" in output
        ), output
        assert "still latched at exit" not in output
    finally:
        if app is not None and app.proc.poll() is None:
            app.proc.kill()
        plant.proc.send_signal(signal.SIGINT)
        plant.finish(30)
        link.close_participant(part)
