"""Recording the running app (#24): every step, plan and config edit into a collect file that replay reads."""

import json
import time

import numpy as np
import pytest

import judo
from judo.collection.replay import read_demos
from judo.runtime.app import App

h5py = pytest.importorskip("h5py")


def small_app(**kwargs) -> App:
    controller = judo.ControllerConfig(horizon=0.3, control_freq=20.0)
    return App("cartpole", "ps", controller_config=controller, seed=0, num_workers=1, **kwargs)


def test_a_recording_holds_the_steps_plans_and_config_edits_and_replay_reads_it(tmp_path, wait_until):
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
        app.update_config("optimizer", {"sigma": 0.2})
        time.sleep(0.2)
        assert app.stop_recording() == path
        assert app.recording is None and app.stop_recording() is None
        second = app.start_recording(path)  # the same file: the next demo
        time.sleep(0.3)
    finally:
        app.stop()  # writes the recording under way
    env_args, demos = read_demos(path)
    assert env_args["task"] == "cartpole" and env_args["source"] == "gui recording" and second == path
    assert sorted(demos) == [0, 1]
    demo = demos[0]
    assert demo.qpos.shape[1] == 2 and len(demo.qpos) > 20
    with h5py.File(path, "r") as file:
        group = file["data/demo_0"]
        knots = group["plan/knots"][:]
        assert knots.shape[0] >= 4 and knots.shape[1:] == (app.controller.optimizer.num_nodes, 1)
        assert np.all(np.diff(group["plan/times"][:]) > 0)
        assert json.loads(group.attrs["env_kwargs"])["optimizer"]["sigma"] != 0.2
        assert json.loads(file["data/demo_1"].attrs["env_kwargs"])["optimizer"]["sigma"] == 0.2  # the edit held
        edits = json.loads(group.attrs["config_edits"])
        assert [(edit["kind"], edit["config"]["sigma"]) for edit in edits] == [("optimizer", 0.2)]
        assert group["actions"].shape == (len(demo.qpos), 1) and np.isfinite(group["rewards"][:]).all()
