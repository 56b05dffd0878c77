"""Readings a robot cannot give are refused and named, as NaN is: a joint beyond its range with a
margin, faster than the model can move it, or at an absurd magnitude; a second robot on the joint
states is refused and warned of; and the stamps the example robot publishes never run back. Against
real publisher and plant processes."""

import logging
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from ros2_links import ROOT, env, free_domain, poll, start_plant, start_publisher, stop_process

from judo.core.errors import JudoError
from judo.ros2 import link, refusals
from judo.ros2.bridge import Ros2System
from judo.ros2.joints import JointLayout
from judo.ros2.options import Ros2Options
from judo.tasks.cartpole import Cartpole

# within the slider's -2..2 with 10% margin, and below the speed bounds
VALID = ([2.3, 50.0], [-399.0, 300.0])
ABSURD = {
    "joint 'hinge' position 1e+300 rad is outside -1e+06 to 1e+06 (an unlimited joint's bound)": (
        [0.1, 1e300],
        [0, 0],
    ),
    "joint 'slider' position 2.5 m is outside -2.4 to 2.4 (its range -2 to 2 with a 10% margin)": (
        [2.5, 0],
        [0, 0],
    ),
    "joint 'hinge' velocity 1000 rad/s is outside +/-314.159 (half a turn in one 0.01 s "
    "physics step)": (
        [0.1, 0],
        [0, 1000],
    ),
    "joint 'slider' velocity -401 m/s is outside +/-400 (its whole range in one 0.01 s "
    "physics step)": (
        [0.1, 0],
        [-401, 0],
    ),
}


def test_cartpoles_bounds_are_its_range_with_a_margin_and_a_step_across_it():
    layout = JointLayout.of(Cartpole().model)
    np.testing.assert_allclose(layout.low, [-2.4, -1e6])
    np.testing.assert_allclose(layout.high, [2.4, 1e6])
    np.testing.assert_allclose(layout.max_speed, [4 / 0.01, np.pi / 0.01])
    assert layout.implausible([0, 1], np.array(VALID[0]), np.array(VALID[1])) is None
    # message order
    assert layout.implausible([1, 0], np.array([1e300, 0.0]), np.zeros(2)) == next(iter(ABSURD))


def test_a_rogue_publisher_of_absurd_joint_states_is_refused_and_named_and_never_becomes_the_reading(  # noqa: E501
    caplog, monkeypatch
):
    monkeypatch.setattr(refusals, "REPORT_EVERY", 0.0)  # every refusal logged, for the test
    domain = free_domain()
    states = [VALID] + list(ABSURD.values())
    rogue = start_publisher(domain, ["slider", "hinge"], states)
    try:
        with caplog.at_level(logging.WARNING, logger="judo.ros2"):
            system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
            try:
                readings = []

                def all_named() -> bool:
                    readings.append(system.read_state().state)
                    return all(named in caplog.text for named in ABSURD)

                poll(all_named, timeout=20, what="each absurd JointState to be refused")
                assert system.refused["joint state (out of bounds)"] >= len(ABSURD)
            finally:
                system.close()
    finally:
        stop_process(rogue)
    for state in readings:  # every reading is the valid JointState: nothing refused is planned from
        np.testing.assert_array_equal(state, VALID[0] + VALID[1])


@pytest.mark.slow
def test_the_app_exits_2_in_a_few_lines_on_a_robot_that_only_sends_1e300():
    domain = free_domain()
    rogue = start_publisher(domain, ["slider", "hinge"], [([0.1, 1e300], [0.0, 0.0])])
    try:
        app = subprocess.run(
            [
                sys.executable,
                "-m",
                "judo",
                "--task",
                "cartpole",
                "--system",
                "ros2",
                "--headless",
                "--duration",
                "4",
            ]
            + ["--ros2.wait-s", "2"],
            capture_output=True,
            text=True,
            env=env(domain),
            cwd=ROOT,
            timeout=120,
        )
    finally:
        stop_process(rogue)
    lines = (app.stdout + app.stderr).strip().splitlines()
    assert app.returncode == 2, lines[-5:]
    assert len(lines) <= 3 and "Nan, Inf or huge value" not in app.stdout + app.stderr, lines[:5]
    assert "refused (joint state (out of bounds))" in lines[-1]
    assert "joint 'hinge' position 1e+300 rad is outside -1e+06 to 1e+06" in app.stderr


@pytest.mark.slow
def test_a_second_plant_on_the_joint_states_is_warned_of_while_running_and_refused_at_start(caplog):
    domain = free_domain()
    first = start_plant(domain)
    second = None
    system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    try:
        assert system.peers.joint_publishers() == 1
        second = start_plant(domain)
        with caplog.at_level(logging.WARNING, logger="judo.ros2"):
            poll(
                lambda: system.step() or "2 publishers write rt/joint_states" in caplog.text,
                timeout=20,
                what="the bridge's warning of a second plant",
            )
        assert (
            f"in domain {domain}, expected 1: readings from a second robot or plant mix in"
            in caplog.text
        )
        system.close()  # its commands writer would be refused first
        with pytest.raises(
            JudoError,
            match=r"2 publishers write rt/joint_states "
            rf"in DDS domain {domain}, expected 1",
        ):
            Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    finally:
        system.close()
        for proc in (first, second):
            if proc is not None:
                stop_process(proc)
    out, _ = second.communicate(timeout=10)
    assert "1 other publisher(s) write rt/joint_states" in out, out  # the plant says so too


@pytest.mark.slow
def test_the_example_robots_stamps_never_run_back_at_a_whole_second():
    from cyclonedds.core import Policy, Qos
    from cyclonedds.sub import DataReader

    from judo.ros2 import messages as msg

    domain = free_domain()
    robot = subprocess.Popen(
        [sys.executable, str(ROOT / "examples" / "10_ros2_robot.py"), "--seconds", "40"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env(domain),
        cwd=ROOT,
    )
    part = link.participant(domain)
    # each message, none replaced
    every = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10_000))
    reader = DataReader(part, link.topic(part, "/joint_states", msg.JointState), every)
    stamps: list[float] = []
    try:
        assert "publishing rt/joint_states" in robot.stdout.readline()

        # its clock's sums of 0.01 s fall a hair short of 3 s and of 4 s
        def past_four_seconds() -> bool:
            stamps.extend(msg.seconds_of(m.header.stamp) for m in link.take(reader, 1000))
            return bool(stamps) and stamps[-1] > 4.05

        poll(past_four_seconds, timeout=40, what="the example's stamps past 4 s")
    finally:
        link.close_participant(part)
        stop_process(robot)
    assert len(stamps) > 100
    steps = np.diff(stamps)
    assert steps.min() > 0, [(a, b) for a, b in zip(stamps, stamps[1:], strict=False) if b <= a][:3]
    # 10 ms steps
    np.testing.assert_allclose(np.array(stamps) * 100, np.round(np.array(stamps) * 100), atol=1e-6)


def test_a_stamp_a_hair_below_a_whole_second_is_that_second_to_the_nanosecond():
    from judo.ros2 import messages as msg

    times, t = [], 0.0
    # a plant's clock, as MuJoCo keeps it: 0.01 s steps summed, 2.99999999999998 s at step 300
    for _ in range(500):
        t += 0.01
        times.append(t)
    stamps = [msg.stamp_of(t) for t in times]
    assert (stamps[299].sec, stamps[299].nanosec) == (3, 0)
    nanoseconds = np.array([s.sec * 1_000_000_000 + s.nanosec for s in stamps])
    np.testing.assert_array_equal(np.diff(nanoseconds), 10_000_000)


def test_a_free_base_far_away_or_too_fast_is_named():
    import mujoco

    from judo.ros2.joints import implausible_base

    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom size="0.5"/></body></worldbody></mujoco>'
    )
    at_rest = np.array([0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0])
    assert implausible_base(model, at_rest, np.zeros(6)) is None
    far = at_rest + np.array([2e6, 0, 0, 0, 0, 0, 0])
    fast = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1e4])
    assert implausible_base(model, far, np.zeros(6)) == (
        "base position 2e+06 m is beyond 1e+06 (physics step 0.002 s)"
    )
    assert (
        implausible_base(model, at_rest, fast)
        == "base angular speed 10000 rad/s is beyond 1570.8 (physics step 0.002 s)"
    )
