"""--system unitree's options on the command line and in TOML, `plant --protocol`, and what the
bridge refuses before any DDS: a model whose actuators are not the robot's motors, a reading with
the wrong motor count."""

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

import leg_task
import mujoco
from unitree_links import free_domain, leg_state

from judo.core.configuration.config_file import load_config
from judo.core.errors import ConfigError
from judo.ros2.options import UnitreeOptions, unitree_options
from judo.runtime import launch
from judo.system_choice import system_class
from judo.unitree import messages as msg
from judo.unitree import motors as mt
from judo.unitree.bridge import UnitreeSystem, reading_of
from judo.unitree.robot import main as plant_main


def test_unitree_options_from_toml_and_the_command_line(tmp_path):
    assert system_class("unitree") is UnitreeSystem
    path = tmp_path / "robot.toml"
    path.write_text(
        'system = "unitree"\n[unitree]\nrobot = "g1"\ndomain = 3\ninterface = "eth0"\nrate_hz = '
        "250\n"
    )
    loaded = load_config(path)
    options = unitree_options(loaded.unitree, "[unitree]")
    assert loaded.system == "unitree"
    assert options == UnitreeOptions(robot="g1", domain=3, interface="eth0", rate_hz=250.0)
    with pytest.raises(
        ConfigError, match="unknown field 'rate'; valid fields are: domain, interface"
    ):
        unitree_options({"rate": 1}, "[unitree]")
    with pytest.raises(
        ConfigError,
        match=r"\[unitree\]: domain must be "
        r"an integer 0..232, got '3'",
    ):
        unitree_options({"domain": "3"}, "[unitree]")
    parsed, _ = launch.parse(
        ["--task", "cartpole", "--unitree.domain", "9", "--unitree.soft-start-s", "1"],
        {},
        None,
        options,
    )
    assert parsed.unitree == UnitreeOptions(
        robot="g1", domain=9, interface="eth0", rate_hz=250.0, soft_start_s=1.0
    )


def test_plant_protocol_and_a_bad_unitree_option_are_one_line(capsys):
    assert (
        plant_main(["--task", "go2_stand", "--protocol", "unitree", "--unitree.rate-hz", "0"]) == 2
    )
    err = capsys.readouterr().err.strip()
    assert err == "python -m judo plant: --unitree.rate-hz must be a positive number, got 0.0"
    with pytest.raises(SystemExit):
        plant_main(["--task", "go2_stand", "--protocol", "dds"])
    assert "unitree" in capsys.readouterr().err


def test_the_bridge_names_a_model_that_is_not_the_robots_motors():
    xml = leg_task.MODEL.read_text().replace(
        '<position name="FR_hip" joint="FR_hip_joint" kp="20" kv="0.5"',
        '<motor name="FR_hip" joint="FR_hip_joint"',
    )
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.raises(ConfigError, match="actuator 'FR_hip' is not a position actuator"):
        mt.Motors.of(model, "go2")
    with pytest.raises(
        ConfigError,
        match="actuator 'FR_hip' drives 'FR_hip_joint', not one of the g1's joints "
        "left_hip_pitch_joint",
    ):
        mt.Motors.of(mujoco.MjModel.from_xml_path(str(leg_task.MODEL)), "g1")
    with pytest.raises(ConfigError, match="--unitree.robot must be one of go2, g1, got 'h1'"):
        mt.Motors.of(mujoco.MjModel.from_xml_path(str(leg_task.MODEL)), "h1")
    with pytest.raises(ConfigError, match="--unitree.soft-start-s must be 0 or more seconds"):
        UnitreeSystem(leg_task.UnitreeLeg(), UnitreeOptions(domain=free_domain(), soft_start_s=-1))


def test_a_reading_with_the_wrong_motor_count_is_refused():
    """A decoded LowState_ always has its type's 20 slots on the wire; a message of another length
    (another robot's layout, a decoder of another IDL) is refused by name."""
    task = leg_task.UnitreeLeg()
    motors = mt.Motors.of(task.model, "go2")
    sensors = mt.Sensors.of(task.model, task.measured, motors)
    state = leg_state(leg_task.STAND, 10)
    values, q = reading_of(state, motors, sensors)
    assert np.allclose(q, leg_task.STAND, atol=1e-6) and np.allclose(
        values[:3], leg_task.STAND, atol=1e-6
    )
    assert values[-4:-1].tolist() == pytest.approx([0.0, 0.0, 9.81])  # the accelerometer
    state.motor_state = state.motor_state[:12]
    assert reading_of(state, motors, sensors) == (
        "lowstate (motor count)",
        "12 motors; a go2 sends 20",
    )
    assert len(msg.HgLowState().motor_state) == mt.ROBOTS["g1"].slots


def test_a_g1_command_echoes_the_robots_mode_machine_and_verifies():
    from judo.core.configuration.registry import make_task
    from judo.unitree import crc

    motors = mt.Motors.of(make_task("g1_stand").model, "g1")
    assert motors.slot.tolist() == list(range(29)) and motors.robot.low_cmd is msg.HgLowCmd
    command = crc.with_crc(mt.low_cmd(motors, np.zeros(29), motors.kp, motors.kd, mode_machine=5))
    assert (command.mode_pr, command.mode_machine) == (0, 5)
    assert [c.mode for c in command.motor_cmd] == [mt.ENABLE] * 29 + [0] * 6  # slots 29-34 unused
    assert command.motor_cmd[3].kp == pytest.approx(motors.kp[3]) and crc.crc_ok(
        msg.HgLowCmd.deserialize(command.serialize())
    )
