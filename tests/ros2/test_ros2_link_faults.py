"""The link fails the way links fail: malformed JointStates and bad stamps are refused and named, a
robot that restarts its clock is followed, and a lossy, late, jittery link (a plant process with
faults) never makes the bridge read a stale or out-of-order state or command anything out of
range."""

import logging
import threading
import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from ros2_links import (
    DdsRobot,
    echo_reader,
    echoes,
    free_domain,
    poll,
    small_controller,
    start_plant,
    stop_process,
)

import judo
from judo.evaluation.sensing import Sensing, choose_estimator
from judo.loop.closed_loop import ClosedLoop
from judo.ros2 import clock as clock_module
from judo.ros2 import link, refusals
from judo.ros2.bridge import Ros2System
from judo.ros2.joints import JointLayout
from judo.ros2.options import Ros2Options
from judo.tasks.cartpole import Cartpole


def test_malformed_joint_states_and_bad_stamps_are_refused_and_named(caplog, monkeypatch):
    monkeypatch.setattr(clock_module, "RESTART_AFTER", 0.3)
    monkeypatch.setattr(refusals, "REPORT_EVERY", 0.0)  # every refusal logged, for the test
    domain = free_domain()
    robot = DdsRobot(domain)
    system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    try:
        robot.stop_streaming()
        good = system.read_state()
        stamp = robot.stamp
        cases = [
            (
                "joint state (names)",
                "missing joints ['hinge']",
                (["slider"], [0.0], [0.0], stamp + 0.01),
            ),
            (
                "joint state (names)",
                "unknown joints ['elbow']",
                (["slider", "hinge", "elbow"], [0.0] * 3, [0.0] * 3, stamp + 0.01),
            ),
            (
                "joint state (wrong lengths)",
                "2 names, 1 positions, 2 velocities",
                (["slider", "hinge"], [0.0], [0.0, 0.0], stamp + 0.01),
            ),
            (
                "joint state (non-finite)",
                "joints ['hinge']",
                (["slider", "hinge"], [0.0, np.nan], [0.0, 0.0], stamp + 0.01),
            ),
            (
                "joint state (stamp)",
                f"went backwards, from {stamp:.3f} s",
                (["slider", "hinge"], [0.0, 0.0], [0.0, 0.0], stamp - 1.0),
            ),
            (
                "joint state (stamp)",
                "from the future",
                (["slider", "hinge"], [0.0, 0.0], [0.0, 0.0], stamp + 60.0),
            ),
        ]
        for kind, named, message in cases:
            before = system.refused.get(kind, 0)
            caplog.clear()
            with caplog.at_level(logging.WARNING, logger="judo.ros2"):
                robot.send(*message)
                poll(
                    lambda kind=kind, before=before: (
                        (system.read_state(), system.refused.get(kind, 0))[1] > before
                    )
                )
            assert named in caplog.text, (kind, caplog.text)
            reading = system.read_state()
            assert reading.time == good.time  # nothing refused ever becomes the reading
            np.testing.assert_array_equal(reading.state, good.state)
        # a robot whose clock restarted at 0 is followed once its stamps stay consistent, its time
        # carried on
        restart_stamps = iter(np.arange(0.01, 5.0, 0.01))
        deadline = time.monotonic() + 3.0
        while system.read_state().time == good.time and time.monotonic() < deadline:
            robot.send(["slider", "hinge"], [0.2, 3.1], [0.0, 0.0], float(next(restart_stamps)))
            time.sleep(0.01)
        after = system.read_state()
        assert after.time > good.time and after.state[0] == pytest.approx(0.2)
    finally:
        system.close()
        robot.close()


def test_joint_positions_alone_become_the_tasks_measured_sensors_and_the_ekf_estimates_the_state():
    domain = free_domain()
    robot = DdsRobot(domain, velocity=False)
    system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    try:
        reading = system.read_state()
        assert reading.state is None
        # slider_pos, hinge_pos: cartpole's measured
        np.testing.assert_array_equal(reading.sensors, [0.1, 3.0])
        name, estimator = choose_estimator(system.task, "cartpole", system, Sensing(), reading)
        assert name == "ekf"
        loop = ClosedLoop(
            small_controller(max_plan_age=0.5), system, clock=time.monotonic, estimator=estimator
        )
        for _ in range(20):
            loop.step()
        # the EKF's: it tracks the measured positions; the pushes it sends move
        estimate = loop.reading.state
        # its model's velocities a little while this robot stands still
        assert np.isfinite(estimate).all()
        np.testing.assert_allclose(estimate[:2], [0.1, 3.0], atol=0.02)
    finally:
        system.close()
        robot.close()


FREE_BASE = """
<mujoco><worldbody>
  <body name="base"><freejoint name="root"/><geom size="0.1"/>
    <body name="leg"><joint name="knee" type="hinge"/><geom size="0.05" pos="0 0 -0.2"/></body>
  </body>
</worldbody>
<actuator><motor joint="knee" ctrlrange="-1 1"/></actuator></mujoco>
"""


class FreeBase(judo.Task):
    def reward(self, states, sensors, controls, config, system_metadata=None):
        return np.zeros(states.shape[0])


def test_a_free_base_comes_from_odometry_and_the_imu_rides_along_in_the_metadata(tmp_path):
    from cyclonedds.pub import DataWriter

    from judo.ros2 import messages as msg

    (tmp_path / "free_base.xml").write_text(FREE_BASE)
    domain = free_domain()
    part = link.participant(domain)
    writers = {
        name: DataWriter(part, link.topic(part, topic, kind), link.SENSOR_QOS)
        for name, topic, kind in (
            ("joints", "/joint_states", msg.JointState),
            ("odom", "/odom", msg.Odometry),
            ("imu", "/imu", msg.Imu),
        )
    }
    layout = JointLayout.of(FreeBase(tmp_path / "free_base.xml").model)
    qpos = np.array([1.0, 2.0, 0.5, np.cos(0.3), 0.0, 0.0, np.sin(0.3), -0.4])  # yawed 0.6 rad
    qvel = np.array([0.5, -0.2, 0.1, 0.01, 0.02, 0.3, 1.5])
    stop = threading.Event()

    def robot() -> None:
        stamp = 1.0
        while not stop.is_set():
            stamp += 0.01
            writers["odom"].write(link.odometry(layout, qpos, qvel, stamp))
            writers["imu"].write(link.imu(qpos, qvel, np.array([0.0, 0.0, 9.81]), layout, stamp))
            writers["joints"].write(link.joint_state(layout, qpos, qvel, stamp))
            time.sleep(0.01)

    thread = threading.Thread(target=robot, daemon=True)
    thread.start()
    try:
        system = Ros2System(FreeBase(tmp_path / "free_base.xml"), Ros2Options(domain_id=domain))
        poll(lambda: "imu" in system.read_state().metadata, what="an Imu")
        reading = system.read_state()
        np.testing.assert_allclose(reading.state, np.concatenate([qpos, qvel]), atol=1e-12)
        np.testing.assert_allclose(reading.metadata["imu"]["linear_acceleration"], [0.0, 0.0, 9.81])
        system.close()
    finally:
        stop.set()
        thread.join()
        link.close_participant(part)


def test_the_bridge_waits_for_a_robot_and_says_what_it_expected():
    with pytest.raises(
        judo.JudoError,
        match=r"no valid sensor_msgs/JointState on "
        r"rt/joint_states in DDS domain \d+",
    ):
        Ros2System(Cartpole(), Ros2Options(domain_id=free_domain(), wait_s=0.2))


@pytest.mark.slow
def test_a_lossy_late_jittery_link_keeps_plans_fresh_and_a_killed_robot_gets_the_safe_action_until_it_is_back():  # noqa: E501
    domain = free_domain()
    proc = start_plant(
        domain,
        "--echo",
        "--latency-ms",
        "50",
        "--jitter-ms",
        "30",
        "--drop",
        "0.2",
        "--duplicate",
        "0.1",
    )
    part, echo = echo_reader(domain)
    system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    loop = ClosedLoop(small_controller(max_plan_age=0.5), system, clock=time.monotonic)
    times, commands = [], []
    try:
        # 1.5 s and 150 commands sent (fewer steps fit in 1.5 s on a loaded machine)
        started = time.monotonic()
        while (
            time.monotonic() - started < 1.5 or len(times) < 150
        ) and time.monotonic() - started < 60:
            record = loop.step()  # raises ReadingTimeError if a reading's time ever went backwards
            assert record is not None
            times.append(record.time)
            commands.extend(echoes(echo))
        poll(  # of 150 sent, a fifth lost and a tenth sent twice: about 130 echoed
            lambda: bool(commands.extend(echoes(echo))) or len(commands) >= 100,
            timeout=20.0,
            what="the plant's echoes",
        )
        # 50-80 ms late and a fifth lost: plans stay within max_plan_age
        assert loop.watchdog.trips == 0
        assert len(loop.update_ms) >= 10
        # the jitter reordered messages: late ones refused
        assert system.refused.get("joint state (stamp)", 0) > 0

        # the robot's process dies: the safe action within max_plan_age beyond a control period
        proc.kill()
        proc.wait()
        killed_at = time.monotonic()
        while loop.watchdog.tripped is None and time.monotonic() - killed_at < 3:
            loop.step()
        # max_plan_age, a control period and the last reading up to 80 ms late, with a second's
        # slack for a busy CI
        assert time.monotonic() - killed_at < 0.5 + 1 / 20 + 1.0
        np.testing.assert_array_equal(system._command, loop.safe_action())
        # and comes back, its clock from 0: followed after a second, plans resume
        proc = start_plant(domain)
        back_at, stale_time = time.monotonic(), loop.reading.time
        while loop.watchdog.tripped is not None and time.monotonic() - back_at < 5:
            loop.step()
        assert loop.watchdog.tripped is None and loop.reading.time > stale_time
    finally:
        system.close()
        link.close_participant(part)
        stop_process(proc)
    assert np.all(np.diff(times) >= 0)
    low, high = Cartpole().command_range.T
    values = np.concatenate(commands)
    assert np.isfinite(values).all() and (values >= low).all() and (values <= high).all()
