"""The EKF and the UKF on tiny nonlinear models: a free body's quaternion and covariance, and delay
compensation."""

import mujoco
import numpy as np
import pytest

from judo.core.estimator import ControlHistory
from judo.core.reading import SystemState
from judo.core.task import Task
from judo.estimators.ekf import EKFConfig, ExtendedKalmanFilter
from judo.estimators.ukf import UKFConfig, UnscentedKalmanFilter
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem

FREE_BODY_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="box" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.02" mass="1"/>
      <site name="imu"/>
    </body>
  </worldbody>
  <sensor>
    <framepos name="box_pos" objtype="body" objname="box"/>
    <framequat name="box_quat" objtype="body" objname="box"/>
    <gyro name="box_gyro" site="imu"/>
  </sensor>
</mujoco>
"""

PENDULUM_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="pole">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.03" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor joint="hinge" ctrlrange="-1 1" gear="3"/></actuator>
  <sensor><jointpos name="hinge_pos" joint="hinge"/></sensor>
</mujoco>
"""

FILTERS = {"ekf": (ExtendedKalmanFilter, EKFConfig), "ukf": (UnscentedKalmanFilter, UKFConfig)}
"""Both Kalman filters, by registered name: the same contract, the same tests."""


def make_task(xml, tmp_path, sensors):
    path = tmp_path / "model.xml"
    path.write_text(xml)

    class Model(Task):
        measured_sensors = sensors

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(len(states))

    return Model(path)


@pytest.mark.parametrize("name", FILTERS)
def test_a_free_body_s_quaternion_stays_normalized_and_its_covariance_positive_definite(
    tmp_path, name
):
    filter_cls, config_cls = FILTERS[name]
    sensors = ("box_pos", "box_quat", "box_gyro")
    plant, planner = (
        make_task(FREE_BODY_XML, tmp_path, sensors),
        make_task(FREE_BODY_XML, tmp_path, sensors),
    )
    plant.data.qvel[:] = [0.3, 0.0, 2.0, 4.0, -3.0, 6.0]  # tumbling while it falls
    mujoco.mj_forward(plant.sim_model, plant.data)
    noise = {"framepos": 0.002, "framequat": 0.02, "gyro": 0.01}
    system = SensedSystem(MujocoSystem(plant), noise=noise, rng=np.random.default_rng(0))
    ekf = filter_cls(planner, config_cls(noise_framequat=0.02))
    controls = ControlHistory(0)
    ekf.reset(system.read_state())
    for _ in range(150):
        system.step()
        estimate = ekf.update(system.read_state(), system.time, controls)
        assert abs(np.linalg.norm(estimate.state[3:7]) - 1.0) < 1e-9
        cov = ekf.covariance()
        assert cov.shape == (12, 12)  # tangent space: 2 nv, not nq + nv
        np.testing.assert_array_equal(cov, cov.T)
        assert np.linalg.eigvalsh(cov).min() > 0
    rotation = np.zeros(3)
    mujoco.mju_subQuat(rotation, estimate.state[3:7], plant.data.qpos[3:7])
    assert np.linalg.norm(rotation) < 0.02  # rad: within the camera's noise
    assert np.linalg.norm(estimate.state[:3] - plant.data.qpos[:3]) < 0.004  # m
    # rad/s: the gyro's noise
    assert np.linalg.norm(estimate.state[10:] - plant.data.qvel[3:]) < 0.05


def run_pendulum(tmp_path, delay, stamp_as_taken=True, steps=300, name="ekf"):
    """Estimate errors (steps,) of the pole angle with readings `delay` s late, noise 0.002 rad, by
    filter `name`."""
    filter_cls, config_cls = FILTERS[name]
    plant = make_task(PENDULUM_XML, tmp_path, ("hinge_pos",))
    planner = make_task(PENDULUM_XML, tmp_path, ("hinge_pos",))
    system = SensedSystem(
        MujocoSystem(plant), noise=0.002, delay=delay, rng=np.random.default_rng(0)
    )
    ekf = filter_cls(planner, config_cls(noise_jointpos=0.002))
    controls = ControlHistory(1)
    ekf.reset(system.read_state())
    torques = np.sin(np.arange(steps) * 0.05) + np.random.default_rng(1).normal(0.0, 0.3, steps)
    errors = []
    for k in range(steps):
        controls.append(system.time, np.array([torques[k]]))
        system.apply(np.array([torques[k]]))
        system.step()
        reading = system.read_state()
        # what a filter without delay compensation sees: a late value called current
        if not stamp_as_taken:
            reading = SystemState(None, system.time, {}, reading.sensors)
        estimate = ekf.update(reading, system.time, controls)
        assert estimate.time == pytest.approx(system.time)
        errors.append(estimate.state[0] - plant.data.qpos[0])
    return np.abs(np.array(errors[100:])), np.abs(plant.data.qvel[0])


@pytest.mark.parametrize("name", FILTERS)
def test_a_delayed_reading_gives_the_estimate_of_an_undelayed_one_within_the_noise(tmp_path, name):
    on_time, _ = run_pendulum(tmp_path, delay=0.0, name=name)
    late, speed = run_pendulum(tmp_path, delay=0.04, name=name)
    naive, _ = run_pendulum(tmp_path, delay=0.04, stamp_as_taken=False, name=name)
    assert on_time.mean() < 0.002 and late.mean() < 0.003  # within the encoder's 0.002 rad
    assert naive.mean() > 20 * late.mean()  # 40 ms of a swinging pole, uncompensated
