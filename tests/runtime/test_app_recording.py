"""Recording the running app: every step, plan and config edit (the estimator's too) into a collect
file that replay reads, with the measured sensors, the estimate and the plans' traces."""

import json
import time

import numpy as np
import pytest

import judo
from judo.runtime.app import App
from judo.runtime.gui.replay_episodes import read_demos

h5py = pytest.importorskip("h5py")


def small_app(**kwargs) -> App:
    controller = judo.ControllerConfig(horizon=0.3, control_freq=20.0)
    return App("cartpole", "ps", controller_config=controller, seed=0, num_workers=1, **kwargs)


def test_a_recording_holds_the_steps_plans_and_config_edits_and_replay_reads_it(
    tmp_path, wait_until
):
    app = small_app(gui=False)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
        path = app.start_recording(tmp_path / "run.h5")
        assert app.recording == path
        with pytest.raises(judo.JudoError, match="already recording to"):
            app.start_recording(tmp_path / "other.h5")
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 4, what="four more plans")
        app.commands.update_config("optimizer", {"sigma": 0.2})
        time.sleep(0.2)
        assert app.stop_recording() == path
        assert app.recording is None and app.stop_recording() is None
        second = app.start_recording(path)  # the same file: the next demo
        time.sleep(0.3)
    finally:
        app.stop()  # writes the recording under way
    env_args, demos = read_demos(path)
    assert (
        env_args["task"] == "cartpole" and env_args["source"] == "gui recording" and second == path
    )
    assert sorted(demos) == [0, 1]
    demo = demos[0]
    assert demo.qpos.shape[1] == 2 and len(demo.qpos) > 20
    with h5py.File(path, "r") as file:
        group = file["data/demo_0"]
        knots = group["plan/knots"][:]
        assert knots.shape[0] >= 4 and knots.shape[1:] == (app.controller.optimizer.num_nodes, 1)
        assert np.all(np.diff(group["plan/times"][:]) > 0)
        assert json.loads(group.attrs["env_kwargs"])["optimizer"]["sigma"] != 0.2
        # the edit held
        assert json.loads(file["data/demo_1"].attrs["env_kwargs"])["optimizer"]["sigma"] == 0.2
        edits = json.loads(group.attrs["config_edits"])
        assert [(edit["kind"], edit["config"]["sigma"]) for edit in edits] == [("optimizer", 0.2)]
        assert (
            group["actions"].shape == (len(demo.qpos), 1) and np.isfinite(group["rewards"][:]).all()
        )


def recorded_demo(path) -> tuple[dict[str, np.ndarray], list[dict]]:
    """({dataset path under demo_0: its array}, its config edits) of a recording's first demo."""
    with h5py.File(path, "r") as file:
        group = file["data/demo_0"]
        arrays = {
            f"{part}/{key}": group[part][key][:] for part in ("obs", "plan") for key in group[part]
        }
        arrays["measured_sensors"] = json.loads(group.attrs.get("measured_sensors", "null"))
        return arrays, json.loads(group.attrs["config_edits"])


def test_a_sensed_recording_keeps_the_measurements_the_estimate_traces_and_estimator_edits(
    tmp_path, wait_until
):
    # encoders into the EKF
    app = small_app(gui=False, observe="sensors", sensor_noise=0.005, sensor_rate=100)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
        path = app.start_recording(tmp_path / "sensed.h5")
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 3, what="three more plans")
        # what the GUI's estimator panel calls
        app.commands.update_estimator_config({"noise_jointpos": 0.01})
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 3, what="three more plans")
    finally:
        app.stop()
    arrays, edits = recorded_demo(path)
    steps, updates = len(arrays["obs/qpos"]), len(arrays["plan/times"])
    assert arrays["measured_sensors"] == ["slider_pos", "hinge_pos"]
    assert (
        arrays["obs/measured"].shape
        == arrays["obs/estimate_qpos"].shape
        == arrays["obs/estimate_qvel"].shape
    )
    assert (
        arrays["obs/measured"].shape == (steps, 2)
        and np.isfinite(arrays["obs/estimate_qpos"]).all()
    )
    # the filter follows the truth
    assert np.abs(arrays["obs/estimate_qpos"] - arrays["obs/qpos"]).max() < 0.2
    traces = arrays["plan/traces"]
    assert traces.dtype == np.float32 and traces.shape[:2] == (
        updates,
        1 + app.controller.config.max_num_traces,
    )
    assert [(edit["kind"], edit["name"], edit["config"]["noise_jointpos"]) for edit in edits] == [
        ("estimator", "ekf", 0.01)
    ]


def test_a_change_of_estimator_is_recorded_and_the_recording_goes_on(tmp_path, wait_until):
    app = small_app(gui=False)  # full state, no estimator
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
        path = app.start_recording(tmp_path / "switch.h5")
        app.commands.update_config("optimizer", {"sigma": 0.2})
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 3, what="three more plans")
        app.commands.switch_estimator("state")  # what the GUI's estimator dropdown calls
        wait_until(lambda: app.session.estimator_name == "state", what="the switch")
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 3, what="three more plans")
        # both carried over
        assert app.recording == path and app.controller.optimizer.config.sigma == 0.2
        app.commands.switch_estimator(None)
        wait_until(lambda: app.session.estimator_name is None, what="the switch back")
        time.sleep(0.2)
    finally:
        app.stop()
    arrays, edits = recorded_demo(path)
    assert [(edit["kind"], edit.get("name")) for edit in edits] == [
        ("optimizer", None), ("estimator", "state"), ("estimator", None)
    ]  # fmt: skip
    assert edits[1]["config"] is not None and edits[2]["config"] is None
    assert edits[0]["time"] <= edits[1]["time"] <= edits[2]["time"]
    # rows while "state" ran, NaN elsewhere
    estimated = np.isfinite(arrays["obs/estimate_qpos"]).all(axis=1)
    assert estimated.any() and not estimated.all() and not estimated[0]
    # a pass-through
    assert np.allclose(arrays["obs/estimate_qpos"][estimated], arrays["obs/qpos"][estimated])
    assert "obs/measured" not in arrays and arrays["measured_sensors"] is None


def test_stopping_a_recording_before_any_step_writes_nothing_and_says_so(tmp_path):
    # never started: the plant takes no step
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    app.start_recording(tmp_path / "empty.h5")
    with pytest.raises(judo.JudoError, match=r"nothing was recorded \(the plant took no step"):
        app.stop_recording()
    assert app.recording is None and not (tmp_path / "empty.h5").exists()
    app.stop()
