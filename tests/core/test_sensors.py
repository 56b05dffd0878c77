"""Measured sensors: validation of Task.measured_sensors, their layout, per-type settings, and that
every built-in task declares a realistic set without changing its rewards' columns."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.errors import ConfigError, UnknownNameError
from judo.core.sensors import InvalidSensorError, measured_layout, parse_per_type, per_sensor
from judo.core.task import Task
from judo.loop.system import MujocoSystem

XML = """
<mujoco>
  <worldbody>
    <body name="arm">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05"/>
      <site name="tip" pos="0 0 -1"/>
    </body>
  </worldbody>
  <actuator><motor joint="hinge"/></actuator>
  <sensor>
    <framepos name="trace_tip" objtype="site" objname="tip"/>
    <jointpos name="hinge_pos" joint="hinge"/>
    <framequat name="arm_quat" objtype="xbody" objname="arm"/>
  </sensor>
</mujoco>
"""


@pytest.fixture
def model_path(tmp_path):
    path = tmp_path / "arm.xml"
    path.write_text(XML)
    return path


def task_measuring(sensor_names):
    class Arm(Task):
        measured_sensors = sensor_names

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(len(states))

    return Arm


def test_layout_lists_columns_types_and_slices_in_the_declared_order(model_path):
    task = task_measuring(("arm_quat", "hinge_pos"))(model_path)
    layout = task.measured
    assert layout.types == ("framequat", "jointpos")
    assert layout.slices == (slice(0, 4), slice(4, 5))
    assert list(layout.columns) == [4, 5, 6, 7, 3]  # trace_tip holds columns 0-2
    assert task.sim_measured is layout


def test_an_unknown_sensor_lists_the_measurable_ones(model_path):
    with pytest.raises(UnknownNameError) as err:
        task_measuring(("hinge_vel",))(model_path)
    assert str(err.value) == (
        "unknown measured sensor of Arm 'hinge_vel'; valid measured sensor of Arms are: "
        "arm_quat, hinge_pos"
    )


def test_a_trace_sensor_is_never_measured(model_path):
    with pytest.raises(
        InvalidSensorError, match="lists trace sensor 'trace_tip' as measured.*arm_quat, hinge_pos"
    ):
        task_measuring(("trace_tip",))(model_path)


def test_a_sensor_listed_twice_is_refused(model_path):
    with pytest.raises(InvalidSensorError, match="'hinge_pos' twice"):
        task_measuring(("hinge_pos", "hinge_pos"))(model_path)


def test_per_type_values_take_a_default_and_refuse_types_not_measured(model_path):
    layout = measured_layout(
        mujoco.MjModel.from_xml_path(str(model_path)), ("hinge_pos", "arm_quat"), "Arm"
    )
    assert per_sensor(0.1, layout, "noise") == [0.1, 0.1]
    assert per_sensor({"default": 0.1, "framequat": 0.02}, layout, "noise") == [0.1, 0.02]
    assert per_sensor({"framequat": 0.02}, layout, "noise") == [None, 0.02]
    # gyro: not measured here
    assert per_sensor({"gyro": 0.1, "jointpos": 0.2}, layout, "noise") == [0.2, None]
    with pytest.raises(
        ConfigError,
        match="'camera' is not a sensor type; valid keys here are: default, framequat, jointpos",
    ):
        per_sensor({"camera": 0.1}, layout, "noise")


def test_parse_per_type_reads_command_line_values():
    assert parse_per_type(["100"], "--sensor-rate-hz") == 100.0
    assert parse_per_type(["100", "framepos=30"], "--sensor-rate-hz") == {
        "default": 100.0,
        "framepos": 30.0,
    }
    with pytest.raises(ConfigError, match="expects NUMBER or TYPE=NUMBER"):
        parse_per_type(["framepos=fast"], "--sensor-rate-hz")


EXPECTED_TYPES = {
    "cartpole": {"jointpos"},
    "pendulum": {"jointpos"},
    "acrobot": {"jointpos"},
    "double_cartpole": {"jointpos"},
    "cylinder_push": {"jointpos"},
    "particle": {"jointpos"},
    "push_t": {"jointpos"},
    "leap_cube": {"jointpos", "framepos", "framequat"},
    "leap_cube_down": {"jointpos", "framepos", "framequat"},
    "fr3_pick": {"jointpos", "framepos", "framequat"},
    "walker": {"jointpos", "framequat", "gyro", "accelerometer"},
    "humanoid_standup": {"jointpos", "framequat", "gyro", "accelerometer"},
    "quadruped": {"jointpos", "framequat", "gyro", "accelerometer", "touch"},
    "quadruped_velocity": {"jointpos", "framequat", "gyro", "accelerometer", "touch"},
}


@pytest.mark.parametrize("task_name", sorted(EXPECTED_TYPES))
def test_every_builtin_task_measures_a_realistic_set(task_name):
    task_cls, _ = judo.get_registered_tasks()[task_name]
    task = task_cls()
    assert set(task.measured.types) == EXPECTED_TYPES[task_name]
    encoders = task.measured.types.count("jointpos")
    hinges_and_slides = sum(
        int(t) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
        for t in task.model.jnt_type
    )
    if task_name == "walker":  # the torso's planar root (x, z, pitch) is not an encoder
        hinges_and_slides -= 3
    if task_name == "fr3_pick":  # the two fingers are coupled: one encoder
        hinges_and_slides -= 1
    assert encoders == hinges_and_slides
    # The plant's measured values are its sensors at its current state.
    values = MujocoSystem(task).sensor_values()
    mujoco.mj_forward(task.sim_model, task.data)
    np.testing.assert_allclose(values, task.data.sensordata[task.sim_measured.columns], atol=1e-12)
