"""The Estimator registry, the "state" pass-through, the EKF's reading checks and ControlHistory."""

import numpy as np
import pytest

import judo
from judo.core.configuration.fields import slider_ranges
from judo.core.configuration.registry import lookup_estimator
from judo.core.errors import UnknownNameError
from judo.core.estimator import ControlHistory, ReadingError, default_estimator_name
from judo.core.reading import SystemState
from judo.estimators.ekf import EKFConfig


def test_unknown_estimator_names_list_the_valid_ones():
    with pytest.raises(UnknownNameError) as err:
        lookup_estimator("particle")
    assert str(err.value) == (
        "unknown estimator 'particle'; valid estimators are: ekf, legged, state, ukf"
    )


def test_estimators_are_made_by_name_with_their_config():
    task = judo.get_registered_tasks()["cartpole"][0]()
    ekf = judo.make_estimator("ekf", task, EKFConfig(noise_jointpos=0.01))
    assert ekf.config.noise_jointpos == 0.01
    assert isinstance(judo.make_estimator("state", task).config, judo.EstimatorConfig)
    judo.set_config_overrides("unregistered_task", EKFConfig, {"history": 0.1})
    assert judo.make_estimator("ekf", task, task_name="unregistered_task").config.history == 0.1
    assert {"noise_jointpos", "process_noise_velocity", "relinearize_every"} <= set(
        slider_ranges(EKFConfig)
    )
    # the task's TOML section for the ukf
    ukf = judo.make_estimator("ukf", task, task_name="cartpole")
    assert ukf.config.process_noise_velocity == 0.02 and ukf.config.spread == 1.0
    assert {"noise_jointpos", "spread"} <= set(slider_ranges(type(ukf.config)))
    assert "relinearize_every" not in slider_ranges(type(ukf.config))  # the EKF's alone


def test_the_state_estimator_passes_a_full_state_through_and_refuses_sensors_only():
    task = judo.get_registered_tasks()["cartpole"][0]()
    estimator = judo.make_estimator("state", task)
    reading = SystemState(np.array([0.1, 3.0, 0.0, 0.2]), 1.5, {"mocap_pos": np.zeros((0, 3))})
    estimate = estimator.update(reading, 1.6, ControlHistory(1))
    np.testing.assert_array_equal(estimate.state, reading.state)
    assert estimate.time == 1.5 and estimate.state is not reading.state
    with pytest.raises(ReadingError, match="needs a full state .* use the 'ekf' estimator"):
        estimator.update(SystemState(None, 1.5, {}, np.zeros(2)), 1.5, ControlHistory(1))


def test_the_ekf_refuses_readings_without_the_measured_sensors():
    task = judo.get_registered_tasks()["cartpole"][0]()
    ekf = judo.make_estimator("ekf", task)
    with pytest.raises(ReadingError, match="needs SystemState.sensors .* got None"):
        ekf.reset(SystemState(np.zeros(4), 0.0))
    with pytest.raises(
        ReadingError,
        match=r"must have shape \(2,\) .*\('slider_pos', "
        r"'hinge_pos'\), got \(3,\)",
    ):
        ekf.reset(SystemState(None, 0.0, {}, np.zeros(3)))


def test_the_default_estimator_follows_what_the_reading_holds():
    cartpole = judo.get_registered_tasks()["cartpole"][0]
    assert default_estimator_name(SystemState(np.zeros(4), 0.0), cartpole) == "state"
    assert default_estimator_name(SystemState(None, 0.0, {}, np.zeros(2)), cartpole) == "ekf"


def test_ekf_config_refuses_non_positive_noise():
    with pytest.raises(judo.ConfigError, match="EKFConfig.noise_gyro must be positive, got 0.0"):
        EKFConfig(noise_gyro=0.0)


def test_control_history_gives_the_action_in_force_and_forgets_old_ones():
    history = ControlHistory(1, span=0.1)
    assert history.at(0.0).tolist() == [0.0]  # nothing applied yet
    for k in range(30):
        history.append(0.01 * k, np.array([float(k)]))
    assert history.at(0.255).tolist() == [25.0]
    assert history.at(0.29).tolist() == [29.0]
    # before the span: the action in force at its start (0.19 s)
    assert history.at(0.0).tolist() == [18.0]
    history.append(0.29, np.array([-1.0]))  # the same instant again: replaced
    assert history.at(0.3).tolist() == [-1.0]


def test_a_config_file_sets_an_estimator_s_fields_per_task(tmp_path):
    path = tmp_path / "judo.toml"
    path.write_text("[estimator_config_overrides.unregistered_task.ekf]\nnoise_jointpos = 0.003\n")
    judo.load_config(path)
    task = judo.get_registered_tasks()["pendulum"][0]()
    assert (
        judo.make_estimator("ekf", task, task_name="unregistered_task").config.noise_jointpos
        == 0.003
    )
    path.write_text("[estimator_config_overrides.pendulum.kalman]\nnoise_jointpos = 0.003\n")
    with pytest.raises(
        judo.ConfigFileError,
        match=r"\[estimator_config_overrides.pendulum.kalman\]: unknown estimator 'kalman'; valid "
        r"estimators are: ekf, legged, state, ukf",
    ):
        judo.load_config(path)
