"""What a sensed episode adds to a collect file: the measured sensors, the estimator's state, and
each plan's traces; a full-state episode without --traces has none of them, and the loop copies no
traces unasked."""

import json

import numpy as np
import pytest

from judo.core.configuration.registry import make_controller, make_estimator
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import PlanRecord
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem
from judo.recording.dataset import DatasetFile
from judo.recording.recorder import EpisodeRecorder
from tests.collection.test_collect_dataset import documented_layout

h5py = pytest.importorskip("h5py")

LAYOUT = documented_layout()

STEPS = 100
"""1 s of cartpole."""


@pytest.fixture(scope="module")
def sensed_file(tmp_path_factory):
    """(path, the controller's last traces): 1 s of cartpole x ps planned through the EKF from
    encoders (std 0.005 rad, 100 Hz, 10 ms late), recorded with traces and written as demo_0."""
    controller = make_controller("cartpole", "ps", seed=0, num_workers=1)
    plant = MujocoSystem.from_task(controller.task, 0)
    sensed = SensedSystem(plant, noise=0.005, delay=0.01, rate=100.0, rng=np.random.default_rng(0))
    estimator = make_estimator("ekf", controller.task, task_name="cartpole")
    recorder = EpisodeRecorder.for_loop(controller, plant.task, traces=True)
    loop = ClosedLoop(controller, sensed, recorders=[recorder], estimator=estimator)
    loop.restart()
    with controller:
        for _ in range(STEPS):
            loop.step()
        assert loop.failed_updates == 0
        last_traces = controller.traces.astype(np.float32)
    path = tmp_path_factory.mktemp("sensed") / "cartpole.h5"
    DatasetFile(path, {"task": "cartpole"}).write_episode(
        recorder.episode(0, np.zeros(STEPS), {}, None)
    )
    return path, last_traces


def test_a_sensed_episode_keeps_the_measured_sensors_and_the_estimate(sensed_file):
    path, _ = sensed_file
    with h5py.File(path, "r") as file:
        demo = file["data/demo_0"]
        qpos = demo["obs/qpos"][:]
        assert json.loads(demo.attrs["measured_sensors"]) == ["slider_pos", "hinge_pos"]
        # m = k = nq = nv = 2: encoders
        for key in ("measured", "measured_age", "estimate_qpos", "estimate_qvel"):
            assert demo["obs"][key].shape == (STEPS, 2) and demo["obs"][key].dtype == np.float64, (
                key
            )
            assert LAYOUT[f"obs/{key}"][1] == "float64"
        measured, estimate = demo["obs/measured"][:], demo["obs/estimate_qpos"][:]
    # the encoders read qpos with 0.005 rad noise, up to 10 ms late; the filter follows the true
    # qpos
    assert np.abs(measured - qpos).max() < 0.2
    assert np.abs(estimate - qpos).max() < 0.05, np.abs(estimate - qpos).max(axis=0)


def test_traces_are_kept_for_every_plan_as_the_controller_drew_them(sensed_file):
    path, last_traces = sensed_file
    with h5py.File(path, "r") as file:
        traces = file["data/demo_0/plan/traces"]
        updates = len(file["data/demo_0/plan/times"])
        assert traces.dtype == np.float32 and LAYOUT["plan/traces"] == (
            "(U, 1 + num_shown, T, num_trace_sensors, 3)",
            "float32",
        )
        # nominal + 5 best
        assert traces.shape == (updates, *last_traces.shape) and last_traces.shape[0] == 6
        assert last_traces.shape[2:] == (1, 3)  # cartpole's one trace sensor, the pole's tip
        assert np.array_equal(traces[-1], last_traces)
        assert not np.array_equal(traces[0], traces[-1])


def test_a_full_state_episode_without_traces_has_none_of_them(tmp_path):
    from judo.collection.episode import collect_episode
    from judo.evaluation.seeded import EpisodeSpec

    path = tmp_path / "plain.h5"
    DatasetFile(path, {"task": "cartpole"}).write_episode(
        collect_episode(EpisodeSpec("cartpole", "ps", 0.1), 0).episode
    )
    with h5py.File(path, "r") as file:
        demo = file["data/demo_0"]
        assert sorted(demo["obs"]) == ["qpos", "qvel", "sensors"]
        assert "traces" not in demo["plan"] and "measured_sensors" not in demo.attrs
        assert len(demo["plan/times"]) == 5


def test_the_loop_copies_traces_only_for_a_recorder_that_wants_them():
    class Plans:
        def __init__(self, wants: bool) -> None:
            self.wants_traces, self.plans = wants, []

        def on_plan(self, record: PlanRecord) -> None:
            self.plans.append(record)

        def on_step(self, record) -> None:
            pass

    for wants in (False, True):
        recorder = Plans(wants)
        with make_controller("cartpole", "ps", seed=0, num_workers=1) as controller:
            loop = ClosedLoop(
                controller, MujocoSystem.from_task(controller.task, 0), recorders=[recorder]
            )
            loop.restart()
            for _ in range(3):
                loop.step()
            traces = [plan.traces for plan in recorder.plans]
            assert len(traces) == 2
            if wants:
                assert all(
                    t.dtype == np.float32 and t.shape == controller.traces.shape for t in traces
                )
                assert traces[-1] is not controller.traces and np.array_equal(
                    traces[-1], controller.traces.astype(np.float32)
                )
            else:
                assert traces == [None, None]


def test_traces_of_plans_that_differ_in_shape_are_padded_and_replay_unpads_them():
    from judo.recording.recorder import padded_stack
    from judo.runtime.gui.replay_episodes import unpadded

    rng = np.random.default_rng(0)
    # horizon and traces edited
    before, after = rng.normal(size=(6, 50, 1, 3)), rng.normal(size=(3, 80, 1, 3))
    stacked = padded_stack([before, after])
    assert stacked.shape == (2, 6, 80, 1, 3) and stacked.dtype == np.float32
    assert np.array_equal(unpadded(stacked[0]), before.astype(np.float32))
    assert np.array_equal(unpadded(stacked[1]), after.astype(np.float32))


def test_collect_with_observe_sensors_records_what_was_measured_and_estimated():
    from judo.collection.episode import collect_episode
    from judo.evaluation.seeded import EpisodeSpec
    from judo.evaluation.sensing import Sensing

    # collect --observe sensors --sensor-* ...
    sensing = Sensing("sensors", noise=0.005, delay=0.01, rate=100.0)
    outcome = collect_episode(EpisodeSpec("cartpole", "ps", 0.3, sensing=sensing), 0)
    episode = outcome.episode
    assert outcome.failure is None and episode is not None
    steps = len(episode.actions)
    assert episode.measured is not None and episode.measured.shape == (steps, 2)
    assert episode.estimate is not None and episode.estimate.shape == (steps, 4)
    assert episode.measured_sensors == ("slider_pos", "hinge_pos")  # Cartpole.measured_sensors
    assert np.abs(episode.estimate[steps // 2 :, :2] - episode.qpos[steps // 2 :]).max() < 0.05
    full = collect_episode(EpisodeSpec("cartpole", "ps", 0.3), 0).episode
    assert full is not None and full.measured is None and full.estimate is None
