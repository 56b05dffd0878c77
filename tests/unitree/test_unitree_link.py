"""The Unitree bridge against a real robot process (`python -m judo plant --protocol unitree`) and
test-side DDS participants on loopback, each test on a random domain: it holds the test leg with
verified commands that ramp in, the robot drops a command with a wrong CRC, and every fault gets
damping, never a stiff command from a stale plan."""

import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

import leg_task
from unitree_links import (
    Streamer,
    Wire,
    drive,
    free_domain,
    leg_options,
    leg_state,
    poll,
    start_robot,
    stiff,
    stop_process,
)

from judo.core.errors import JudoError
from judo.unitree import crc
from judo.unitree import motors as mt
from judo.unitree.bridge import UnitreeSystem

pytestmark = pytest.mark.slow


def test_bridge_holds_the_leg_with_verified_ramped_commands():
    domain = free_domain()
    # both ends on the loopback interface by name
    robot = start_robot(domain, "--unitree.interface", "lo")
    wire = Wire(domain, interface="lo")
    task = leg_task.UnitreeLeg()
    system = UnitreeSystem(task, leg_options(domain, soft_start_s=2.0, interface="lo"))
    try:
        reached = []

        def near_stand() -> bool:
            drive(system, leg_task.STAND, 0.1)
            q = system.read_state().sensors[:3]
            reached.append(q)
            return bool(np.abs(q - leg_task.STAND).max() < 0.08)

        poll(near_stand, timeout=30.0, what="the leg at its stand pose")
        # past the end of the soft start however slowly the loop ran
        drive(system, leg_task.STAND, 2.5)
        commands = [c for c in wire.taken_commands() if stiff(c)]
        assert commands and all(crc.crc_ok(c) for c in commands)
        first, last = commands[0], commands[-1]
        assert bytes(first.head) == b"\xfe\xef" and first.level_flag == 0xFF
        assert [first.motor_cmd[s].mode for s in range(20)] == [mt.ENABLE] * 20
        kp = [c.motor_cmd[1].kp for c in commands]
        assert min(kp) < 0.5 * 20.0 and kp[-1] == pytest.approx(20.0)  # ramped in to the model's kp
        assert last.motor_cmd[1].kd == pytest.approx(0.5) and last.motor_cmd[1].q == pytest.approx(
            0.67, abs=1e-6
        )
        # an unused motor
        assert last.motor_cmd[5].kp == 0 and last.motor_cmd[5].q == pytest.approx(mt.POS_STOP)
        assert system.refused == {}
        system.halt()
        halted = wire.taken_commands()[-1]
        assert not stiff(halted) and halted.motor_cmd[0].kd == pytest.approx(mt.DAMPING_KD)
    finally:
        system.close()
        wire.close()
        stop_process(robot)


def test_the_robot_drops_a_command_with_a_wrong_crc():
    domain = free_domain()
    robot = start_robot(domain, "--unitree.silence-s", "0.5")
    wire = Wire(domain, commands=True)
    try:
        model = leg_task.UnitreeLeg().model
        motors = mt.Motors.of(model, "go2")
        target = np.array([-0.6, 0.67, -1.3])  # the hip against the way it sags under gravity

        def send(good: bool, seconds: float) -> None:
            for _ in range(int(seconds / 0.005)):
                command = crc.with_crc(mt.low_cmd(motors, target, motors.kp, motors.kd))
                if not good:
                    command.crc ^= 1
                wire.command_writer.write(command)
                time.sleep(0.005)

        send(False, 1.5)
        hip = wire.latest_state().motor_state[0].q
        assert hip > -0.2, hip  # never driven there
        send(True, 1.5)
        hip = wire.latest_state().motor_state[0].q
        assert abs(hip + 0.6) < 0.1, hip
    finally:
        wire.close()
        stop_process(robot)
    output = robot.stdout.read() if robot.stdout else ""
    assert "dropped command with a wrong CRC" in output


def test_a_killed_robot_gets_damping_then_a_soft_start_from_its_new_pose():
    domain = free_domain()
    robot = start_robot(domain)
    wire = Wire(domain)
    system = UnitreeSystem(
        leg_task.UnitreeLeg(), leg_options(domain, soft_start_s=1.0, silence_s=0.3)
    )
    try:
        drive(system, leg_task.STAND, 1.5)
        robot.kill()  # no goodbye on the wire
        robot.wait()
        wire.taken_commands()
        poll(
            lambda: (drive(system, leg_task.STAND, 0.05), system.damping_sent > 5)[1],
            timeout=20,
            what="damping",
        )
        drive(system, leg_task.STAND, 0.3)
        tail = wire.taken_commands()[-20:]
        assert tail and not any(stiff(c) for c in tail) and all(crc.crc_ok(c) for c in tail)
        robot = start_robot(domain)  # a new robot: its readings come again, from its own start pose
        after: list = []

        def stiff_again() -> bool:
            drive(system, leg_task.STAND, 0.05)
            after.extend(c for c in wire.taken_commands() if stiff(c))
            return bool(after)

        poll(stiff_again, 30, "stiff commands to the new robot")
        # the ramp begins again, not the plan at full stiffness
        assert after[0].motor_cmd[1].kp < 10.0
    finally:
        system.close()
        wire.close()
        stop_process(robot)


@pytest.mark.parametrize(
    "kind, bad",
    [
        ("lowstate (non-finite)", lambda tick: leg_state([np.nan, 0.67, -1.3], tick)),
        ("lowstate (tick)", lambda tick: leg_state(leg_task.STAND, tick - 500)),
        (
            "lowstate (imu)",
            lambda tick: leg_state(leg_task.STAND, tick, quaternion=(0.0, 0.0, 0.0, 0.0)),
        ),
        ("lowstate (out of bounds)", lambda tick: leg_state([0.0, 0.67, 1.0], tick)),
    ],
)
def test_refused_readings_are_named_and_get_damping(kind, bad):
    domain = free_domain()
    wire = Wire(domain)
    streamer = Streamer(wire)
    system = UnitreeSystem(leg_task.UnitreeLeg(), leg_options(domain, silence_s=0.2))
    try:
        drive(system, leg_task.STAND, 0.5)
        assert system.refused == {}
        wire.taken_commands()
        start_tick = streamer.tick
        streamer.make = lambda tick: (
            bad(tick) if tick > start_tick + 0 else leg_state(leg_task.STAND, tick)
        )
        poll(
            lambda: (drive(system, leg_task.STAND, 0.05), system.refused.get(kind, 0) > 10)[1],
            20,
            kind,
        )
        drive(system, leg_task.STAND, 0.4)
        # silence of valid readings: damping
        assert not any(stiff(c) for c in wire.taken_commands()[-10:])
    finally:
        streamer.stop()
        system.close()
        wire.close()


def test_a_second_commander_is_refused_at_start():
    domain = free_domain()
    wire = Wire(domain, commands=True)
    streamer = Streamer(wire)
    try:
        with pytest.raises(JudoError, match="already writes rt/lowcmd"):
            UnitreeSystem(leg_task.UnitreeLeg(), leg_options(domain))
    finally:
        streamer.stop()
        wire.close()
