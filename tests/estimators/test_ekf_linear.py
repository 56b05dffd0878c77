"""On a linear model the EKF and the UKF are the Kalman filter: a slide joint with a motor under
Euler integration."""

import mujoco
import numpy as np
import pytest

from judo.core.estimator import ControlHistory
from judo.core.reading import SystemState
from judo.core.task import Task
from judo.estimators.ekf import RESET_ITERATIONS, EKFConfig, ExtendedKalmanFilter
from judo.estimators.ukf import UKFConfig, UnscentedKalmanFilter

SLIDER_XML = """
<mujoco>
  <option timestep="0.01" integrator="Euler" gravity="0 0 0"/>
  <worldbody>
    <body name="cart">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass="2" diaginertia="1 1 1"/>
    </body>
  </worldbody>
  <actuator><motor joint="slide" gear="3"/></actuator>
  <sensor><jointpos name="slide_pos" joint="slide"/></sensor>
</mujoco>
"""
MASS, GEAR, DT = 2.0, 3.0, 0.01


class Slider(Task):
    measured_sensors = ("slide_pos",)

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return np.zeros(len(states))


def kalman_filter(readings, controls, config):
    """The textbook Kalman filter of x' = A x + B u, y = x[0] + noise: (K, 2) estimates, (K, 2, 2)
    covariances."""
    A = np.array([[1.0, DT], [0.0, 1.0]])  # Euler: v' = v + dt a, q' = q + dt v'
    B = np.array([DT * DT, DT]) * GEAR / MASS
    H = np.array([[1.0, 0.0]])
    Q = np.diag([config.process_noise_position**2, config.process_noise_velocity**2]) * DT
    R = np.array([[config.noise_jointpos**2]])
    x = np.zeros(2)
    P = np.diag([config.initial_position_std**2, config.initial_velocity_std**2])
    estimates, covariances = [], []
    for k, y in enumerate(readings):
        if k:
            x = A @ x + B * controls[k - 1]
            P = A @ P @ A.T + Q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + K @ (np.array([y]) - H @ x)
        IKH = np.eye(2) - K @ H
        P = IKH @ P @ IKH.T + K @ R @ K.T
        estimates.append(x.copy())
        covariances.append(P.copy())
    return np.array(estimates), np.array(covariances)


@pytest.mark.parametrize(
    "filter_cls, config_cls, extra",
    [
        (ExtendedKalmanFilter, EKFConfig, {}),
        # the cubature rule: exact on linear models
        (UnscentedKalmanFilter, UKFConfig, {"spread": 1.0}),
        (UnscentedKalmanFilter, UKFConfig, {"spread": 0.3}),  # and at any spread
    ],
    ids=["ekf", "ukf", "ukf-spread-0.3"],
)
def test_the_filter_equals_the_exact_kalman_filter_on_a_linear_system(
    tmp_path, filter_cls, config_cls, extra
):
    path = tmp_path / "slider.xml"
    path.write_text(SLIDER_XML)
    task = Slider(path)
    rng = np.random.default_rng(0)
    steps = 200
    controls = rng.uniform(-1.0, 1.0, steps)
    # any sequence will do: both filters see the same
    readings = np.cumsum(rng.normal(0.0, 0.01, steps)) + 0.3
    config = config_cls(
        process_noise_position=0.02, process_noise_velocity=0.5, noise_jointpos=0.01, **extra
    )
    ekf = filter_cls(task, config)
    history = ControlHistory(task.nu)
    expected, expected_cov = kalman_filter(readings, controls, config)
    for k in range(steps):
        reading = SystemState(None, k * DT, {}, np.array([readings[k]]))
        if k == 0:
            ekf.reset(reading)
            estimate = ekf.update(reading, 0.0, history)
        else:
            estimate = ekf.update(reading, k * DT, history)
        np.testing.assert_allclose(estimate.state, expected[k], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ekf.covariance(), expected_cov[k], rtol=0, atol=1e-9)
        assert estimate.time == k * DT
        history.append(k * DT, np.array([controls[k]]))
    if filter_cls is ExtendedKalmanFilter:
        # one finite-difference Jacobian per step at relinearize_every=1
        assert ekf.linearizations >= steps
    else:
        assert ekf.linearizations <= RESET_ITERATIONS  # sigma points after the first reading


def test_model_is_linear_as_the_reference_assumes(tmp_path):
    """The reference's A and B are MuJoCo's own Euler step of this model."""
    model = mujoco.MjModel.from_xml_string(SLIDER_XML)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.ctrl[:] = 0.2, -0.4, 0.7
    mujoco.mj_step(model, data)
    velocity = -0.4 + DT * GEAR * 0.7 / MASS
    np.testing.assert_allclose(
        [data.qpos[0], data.qvel[0]], [0.2 + DT * velocity, velocity], atol=1e-15
    )
