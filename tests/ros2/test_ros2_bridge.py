"""The ROS 2 bridge against a real plant process (`python -m judo plant`) over DDS on loopback:
readings in, commands out, the writer check, the MCAP log, the watchdog when the robot pauses, and
the app's stop."""

import dataclasses
import os
import signal
import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds")
mcap_reader = pytest.importorskip("mcap_ros2.reader")

from ros2_links import (  # noqa: E402
    echo_reader,
    echoes,
    free_domain,
    poll,
    small_controller,
    start_plant,
    stop_process,
)

import judo  # noqa: E402
from judo.core.configuration.registry import make_config  # noqa: E402
from judo.core.errors import JudoError  # noqa: E402
from judo.loop.closed_loop import ClosedLoop  # noqa: E402
from judo.loop.system import MujocoSystem  # noqa: E402
from judo.optimizers.mppi import MPPIConfig  # noqa: E402
from judo.ros2 import link  # noqa: E402
from judo.ros2.bridge import Ros2System  # noqa: E402
from judo.ros2.mcap_log import McapLog  # noqa: E402
from judo.ros2.options import Ros2Options  # noqa: E402
from judo.runtime.app import App  # noqa: E402
from judo.tasks.cartpole import Cartpole  # noqa: E402
from judo.tasks.particle import Particle  # noqa: E402


def bridge(domain: int, log: McapLog | None = None) -> Ros2System:
    return Ros2System(Cartpole(), Ros2Options(domain_id=domain), log)


def test_readings_come_from_the_plant_and_commands_reach_it_and_a_second_writer_is_refused(
    plant, tmp_path
):
    _, domain = plant
    part, echo = echo_reader(domain)
    system = bridge(domain, McapLog(tmp_path / "run.mcap"))
    try:
        first = system.read_state()
        assert (
            first.state is not None and first.state.shape == (4,) and np.isfinite(first.state).all()
        )
        poll(lambda: system.read_state().time > first.time, what="a newer reading")
        assert system.timestep == pytest.approx(0.01)
        system.apply(np.array([0.5]))
        system.step()
        poll(
            lambda: any(np.array_equal(e, [0.5]) for e in echoes(echo)),
            what="the plant to read the command",
        )
        system.apply(np.array([1e6]))  # clamped to cartpole's ctrlrange
        system.step()
        high = float(system.task.command_range[0, 1])
        poll(
            lambda: any(np.array_equal(e, [high]) for e in echoes(echo)), what="the clamped command"
        )
        with pytest.raises(
            JudoError,
            match=r"refused a command of shape "
            r"\(1,\) \(expected \(1,\), finite\)",
        ):
            system.apply(np.array([np.nan]))
        with pytest.raises(
            JudoError,
            match=r"another participant .* already "
            r"writes commands on rt/judo/commands",
        ):
            bridge(domain)
    finally:
        system.close()
        link.close_participant(part)
    logged = {}
    for message in mcap_reader.read_ros2_messages(tmp_path / "run.mcap"):
        logged.setdefault(message.channel.topic, []).append(message)
    assert {topic: ms[0].schema.name for topic, ms in logged.items()} == {
        "/joint_states": "sensor_msgs/msg/JointState",
        "/judo/commands": "std_msgs/msg/Float64MultiArray",
        # the plant's record of what it applied
        "/judo/commands_applied": "sensor_msgs/msg/JointState",
    }
    assert [list(m.ros_msg.data) for m in logged["/judo/commands"]] == [[0.5], [high]]
    assert list(logged["/judo/commands_applied"][-1].ros_msg.effort) == [high]
    assert list(logged["/joint_states"][0].ros_msg.name) == ["slider", "hinge"]


def test_a_paused_robot_gets_the_safe_action_within_max_plan_age_and_plans_resume_when_it_is_back(
    plant,
):
    proc, domain = plant
    controller = small_controller(max_plan_age=0.2)
    system = bridge(domain)
    loop = ClosedLoop(controller, system, clock=time.monotonic)
    limit = 0.2 + 1 / 20.0  # max_plan_age beyond one control period
    try:
        deadline = time.monotonic() + 0.6
        while time.monotonic() < deadline:
            loop.step()
        assert loop.watchdog.trips == 0 and len(loop.update_ms) >= 3
        os.kill(proc.pid, signal.SIGSTOP)
        paused_at = time.monotonic()
        try:
            while loop.watchdog.tripped is None and time.monotonic() - paused_at < 3:
                loop.step()
            tripped_after = time.monotonic() - paused_at
            # the readings froze (or the plan before them aged first)
            assert loop.watchdog.tripped is not None
            # in time, even with a reading up to 10 ms old at the pause
            assert tripped_after < limit + 0.25
            # what the robot is sent now
            np.testing.assert_array_equal(system._command, loop.safe_action())
            stale_plans = len(loop.update_ms)
            for _ in range(5):
                loop.step()
            assert len(loop.update_ms) == stale_plans  # no plan from a reading that stands still
        finally:
            os.kill(proc.pid, signal.SIGCONT)
        resumed_at = time.monotonic()
        while loop.watchdog.tripped is not None and time.monotonic() - resumed_at < 3:
            loop.step()
        assert loop.watchdog.tripped is None and len(loop.update_ms) > stale_plans
        assert time.monotonic() - resumed_at < 1.0
    finally:
        system.close()


def test_the_app_on_the_bridge_records_hdf5_stops_within_a_second_and_leaves_the_robot_the_safe_action(  # noqa: E501
    plant, tmp_path
):
    from judo.runtime.gui.replay_episodes import read_demos

    _, domain = plant
    part, echo = echo_reader(domain)
    system = bridge(domain)
    controller_config = judo.ControllerConfig(horizon=0.5, control_freq=20.0)
    app = App(
        "cartpole",
        "mppi",
        controller_config=controller_config,
        optimizer_config=dataclasses.replace(make_config(MPPIConfig, "cartpole"), num_rollouts=16),
        system=system,
        gui=False,
        num_workers=1,
        seed=0,
    )
    try:
        app.start()
        poll(lambda: app.stats.num_plans() >= 2, timeout=10, what="two plans")
        # the app's own HDF5 recorder, on the bridge
        path = app.start_recording(tmp_path / "run.h5")
        plans = app.stats.num_plans()
        poll(lambda: app.stats.num_plans() >= plans + 3, timeout=10, what="three more plans")
        started = time.monotonic()
        app.stop()
        assert time.monotonic() - started < 1.0
        safe = Cartpole().safe_action(system.read_state().state)
        poll(
            lambda: any(np.allclose(e, safe) for e in echoes(echo)),
            what="the safe action at the robot",
        )
    finally:
        system.close()
        link.close_participant(part)
    _, demos = read_demos(path)
    demo = demos[0]
    assert demo.qpos.shape[1] == 2 and len(demo.qpos) > 5 and np.isfinite(demo.qpos).all()


def test_a_task_with_a_goal_plans_from_the_robot_sides_goal_as_in_process():
    domain = free_domain()
    # particle's goal is a mocap body, drawn by the seed
    proc = start_plant(domain, "--seed", "3", task="particle")
    try:
        system = Ros2System(Particle(), Ros2Options(domain_id=domain))
        try:
            poll(lambda: "mocap_pos" in system.read_state().metadata, what="the goal's PoseArray")
            reading = system.read_state()
        finally:
            system.close()
    finally:
        stop_process(proc)
    expected = MujocoSystem.from_task(Particle(), 3).read_state().metadata
    # a goal away from the origin, as the plant drew it
    assert np.abs(expected["mocap_pos"]).max() > 0.0
    np.testing.assert_allclose(reading.metadata["mocap_pos"], expected["mocap_pos"], atol=1e-12)
    np.testing.assert_allclose(reading.metadata["mocap_quat"], expected["mocap_quat"], atol=1e-12)
