"""Each task's own filter by default: `Task.default_estimator` ("ukf" for walker and leap_cube,
"ekf" for the others) wherever --estimator is not given, as the app, evaluate, tune, collect, titles
and JSON resolve it, an explicit --estimator winning; and a filter that cannot read the plant names
itself in the error."""

import numpy as np
import pytest

import judo
from judo.core.configuration.registry import lookup_task
from judo.core.errors import ConfigError
from judo.core.estimator import ReadingError, default_estimator_name, estimator_in_force
from judo.core.reading import SystemState
from judo.estimators.ekf import EKFConfig
from judo.estimators.ukf import UnscentedKalmanFilter
from judo.evaluation.episode_args import EpisodeArgs
from judo.evaluation.sensing import Sensing
from judo.runtime.launch import _peek
from judo.runtime.session import build_session

DEFAULTS = {
    "walker": "ukf",
    "leap_cube": "ukf",
    "cartpole": "ekf",
    "acrobot": "ekf",
    "pendulum": "ekf",
}


@pytest.mark.parametrize("task", sorted(DEFAULTS))
def test_the_task_names_its_filter_and_an_explicit_one_wins(task):
    task_cls = lookup_task(task)[0]
    assert task_cls.default_estimator == DEFAULTS[task]
    assert estimator_in_force("sensors", None, task_cls) == DEFAULTS[task]
    assert estimator_in_force("state", None, task_cls) is None  # the true state, as it is
    assert estimator_in_force("sensors", "ekf", task_cls) == "ekf"
    assert estimator_in_force("state", "state", task_cls) == "state"
    assert (
        default_estimator_name(SystemState(None, 0.0, {}, np.zeros(2)), task_cls) == DEFAULTS[task]
    )
    assert default_estimator_name(SystemState(np.zeros(4), 0.0), task_cls) == "state"


def test_every_default_is_a_registered_estimator():
    registered = judo.get_registered_estimators()
    assert {
        task_cls.default_estimator for task_cls, _ in judo.get_registered_tasks().values()
    } <= set(registered)


def test_evaluate_tune_and_collect_titles_and_json_name_the_tasks_filter():
    walker = EpisodeArgs(task="walker", optimizer="ps", observe="sensors")
    assert walker.sensing_label() == ", sensors + ukf"
    assert walker.sensing_record()["estimator"] == "ukf"
    # resolved per task by choose_estimator, as in the app
    assert walker.sensing().estimator is None
    cartpole = EpisodeArgs(task="cartpole", optimizer="ps", observe="sensors")
    assert (
        cartpole.sensing_label() == ", sensors + ekf"
        and cartpole.sensing_record()["estimator"] == "ekf"
    )
    named = EpisodeArgs(task="walker", optimizer="ps", observe="sensors", estimator="ekf")
    assert (
        named.sensing_label() == ", sensors + ekf" and named.sensing_record()["estimator"] == "ekf"
    )


def test_the_app_cli_pins_a_filter_only_when_one_is_named():
    assert _peek(["--task", "walker", "--observe", "sensors"])[3:] == ("ukf", False)
    assert _peek(["--task", "cartpole", "--observe", "sensors"])[3:] == ("ekf", False)
    assert _peek(["--task", "walker"])[3:] == (None, False)
    assert _peek(["--task", "walker", "--observe", "sensors", "--estimator", "ekf"])[3:] == (
        "ekf",
        True,
    )
    assert _peek(["--task", "walker", "--observe", "sensors", "--estimator-config.spread", "0.5"])[
        3:
    ] == ("ukf", True)


def test_one_sensing_builds_each_tasks_own_filter_as_a_gui_switch_does():
    sensing = Sensing(observe="sensors")  # no --estimator: the app's sensing across task switches
    walker = build_session("walker", "ps", 0, sensing=sensing, seed=0, num_workers=1)
    cartpole = build_session("cartpole", "ps", 1, sensing=sensing, seed=0, num_workers=1)
    try:
        # the GUI's dropdown and title show session.estimator_name
        assert walker.estimator_name == "ukf"
        assert isinstance(walker.closed_loop.estimator, UnscentedKalmanFilter)
        assert cartpole.estimator_name == "ekf"
        assert type(cartpole.closed_loop.estimator).__name__ == "ExtendedKalmanFilter"
    finally:
        walker.close()
        cartpole.close()


def test_a_config_for_another_filter_than_the_tasks_default_is_refused():
    # meant for the ekf, on walker's ukf
    sensing = Sensing(observe="sensors", estimator_config=EKFConfig())
    with pytest.raises(ConfigError) as err:
        build_session("walker", "ps", 0, sensing=sensing, seed=0, num_workers=1)
    assert str(err.value) == (
        "estimator_config is a EKFConfig, but walker's default estimator 'ukf' takes a "
        "UKFConfig; name the "
        "estimator it is for (estimator=...)"
    )


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_a_filter_on_a_full_state_plant_names_itself(name):
    task = lookup_task("cartpole")[0]()
    with pytest.raises(ReadingError) as err:
        judo.make_estimator(name, task).reset(SystemState(np.zeros(4), 0.0))
    assert str(err.value).startswith(
        f"the {name} estimator needs SystemState.sensors (the values of Cartpole."
    )
