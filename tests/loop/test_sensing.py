"""SensedSystem: the simulator seen through measured sensors, with per-type noise, delay and
rate."""

import mujoco
import numpy as np
import pytest

from judo.core.errors import ConfigError
from judo.core.task import Task
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem

XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="pole">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.03" mass="1"/>
      <site name="tip" pos="0 0 0.5"/>
    </body>
  </worldbody>
  <actuator><motor joint="hinge"/></actuator>
  <sensor>
    <framepos name="trace_tip" objtype="site" objname="tip"/>
    <jointpos name="hinge_pos" joint="hinge"/>
    <framepos name="tip_pos" objtype="site" objname="tip"/>
    <framequat name="pole_quat" objtype="xbody" objname="pole"/>
  </sensor>
</mujoco>
"""


@pytest.fixture
def task(tmp_path):
    path = tmp_path / "pole.xml"
    path.write_text(XML)

    class Pole(Task):
        measured_sensors = ("hinge_pos", "tip_pos", "pole_quat")

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(len(states))

    pole = Pole(path)
    pole.data.qvel[0] = 2.0  # swinging, so every reading differs from the last
    mujoco.mj_forward(pole.sim_model, pole.data)
    return pole


def true_values(task):
    """(8,) the measured sensors at the plant's current state."""
    return MujocoSystem(task).sensor_values()


def test_it_serves_only_the_measured_sensors_noiseless_by_default(task):
    system = SensedSystem(MujocoSystem(task))
    for _ in range(3):
        system.step()
        reading = system.read_state()
        assert reading.state is None and reading.time == pytest.approx(system.time)
        np.testing.assert_allclose(reading.sensors, true_values(task), atol=1e-12)
        assert reading.sensors.shape == (8,)
        assert "mocap_pos" in reading.metadata


def test_a_slow_late_camera_is_held_and_stamped_when_taken(task):
    system = SensedSystem(
        MujocoSystem(task), delay={"framepos": 0.03, "framequat": 0.03}, rate={"framepos": 50}
    )
    taken = {}
    for _ in range(10):
        system.step()
        taken[round(system.time, 6)] = true_values(task)
        reading = system.read_state()
        hinge_time, tip_time, quat_time = reading.metadata["sensor_times"]
        assert hinge_time == pytest.approx(system.time)  # the encoder: every step, at once
        np.testing.assert_allclose(reading.sensors[0], taken[round(hinge_time, 6)][0], atol=1e-12)
        expected_tip = max(
            [0.0, *[t for t in np.arange(0.02, 0.11, 0.02) if t + 0.03 <= system.time + 1e-9]]
        )
        assert tip_time == pytest.approx(expected_tip)  # 50 Hz, 30 ms late, held between
        assert quat_time == pytest.approx(max(0.0, system.time - 0.03))
        if tip_time > 0:
            np.testing.assert_allclose(
                reading.sensors[1:4], taken[round(tip_time, 6)][1:4], atol=1e-12
            )
        assert reading.time == pytest.approx(system.time)  # the newest stamp


def test_noise_has_the_std_asked_for_per_type_and_quaternions_stay_unit(task):
    system = SensedSystem(
        MujocoSystem(task),
        noise={"jointpos": 0.01, "framequat": 0.05},
        rng=np.random.default_rng(0),
    )
    errors, angles = [], []
    for _ in range(1000):
        system.step()
        reading, truth = system.read_state(), system.system.sensor_values()
        errors.append(reading.sensors[:4] - truth[:4])
        assert np.linalg.norm(reading.sensors[4:]) == pytest.approx(1.0, abs=1e-12)
        rotation = np.zeros(3)
        mujoco.mju_subQuat(rotation, reading.sensors[4:], truth[4:])
        angles.append(rotation)
    errors = np.array(errors)
    assert errors[:, 0].std() == pytest.approx(0.01, rel=0.08)
    np.testing.assert_array_equal(errors[:, 1:], 0.0)  # framepos: no noise asked for
    assert np.array(angles).std(axis=0) == pytest.approx([0.05] * 3, rel=0.08)


def test_bad_settings_say_what_is_wrong(task):
    with pytest.raises(ConfigError, match="sensor delay must be at least 0"):
        SensedSystem(MujocoSystem(task), delay=-0.01)
    with pytest.raises(ConfigError, match="sensor rate must be above 0 Hz"):
        SensedSystem(MujocoSystem(task), rate={"jointpos": 0.0})
    with pytest.raises(ConfigError, match="'camera' is not a sensor type"):
        SensedSystem(MujocoSystem(task), rate={"camera": 30.0})


def test_a_task_without_measured_sensors_says_what_to_add(task, tmp_path):
    class Unsensed(Task):
        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(len(states))

    with pytest.raises(
        ConfigError,
        match="Unsensed declares no measured sensors; list .* in Unsensed.measured_sensors",
    ):
        SensedSystem(MujocoSystem(Unsensed(tmp_path / "pole.xml")))


def test_sensing_never_changes_the_physics(task, tmp_path):
    """A plant read through SensedSystem every step follows the same trajectory as one never
    read."""
    other = type(task)(tmp_path / "pole.xml")
    other.data.qvel[0] = 2.0
    mujoco.mj_forward(other.sim_model, other.data)
    sensed, plain = SensedSystem(MujocoSystem(task)), MujocoSystem(other)
    for k in range(100):
        for system in (sensed, plain):
            system.apply(np.array([np.sin(0.1 * k)]))
            system.step()
        sensed.read_state()
    np.testing.assert_array_equal(task.data.qpos, other.data.qpos)
    np.testing.assert_array_equal(task.data.qvel, other.data.qvel)
