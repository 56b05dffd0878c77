"""Latency compensation: the reading predicted on the planning model to when the plan takes effect, under the
controls the plant gets meanwhile, is what the controller plans from (real MuJoCo physics, cartpole)."""

import dataclasses

import numpy as np
import pytest

from judo.core.controller import ControllerConfig
from judo.core.registry import make_controller
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.loop.closed_loop import ClosedLoop
from judo.loop.latency import LatencyPredictor
from judo.loop.system import MujocoSystem


def test_the_prediction_is_the_plant_stepped_under_the_same_controls():
    controller = make_controller("cartpole", "ps", seed=0, num_workers=1)
    with controller:
        plant = MujocoSystem.from_task(controller.task, 0)
        reading = plant.read_state()
        push = lambda now: np.array([0.3 + now])  # noqa: E731  (a control that changes with time)
        predicted = LatencyPredictor(controller.task).predict_reading(reading, 0.05, push)
        for _ in range(round(0.05 / plant.timestep)):
            plant.apply(push(plant.task.data.time))
            plant.step()
        truth = plant.read_state()
        assert predicted.time == pytest.approx(truth.time)
        np.testing.assert_allclose(predicted.state, truth.state, atol=1e-12)
        assert predicted.metadata is reading.metadata
        same = LatencyPredictor(controller.task).predict_reading(reading, 0.2 * plant.timestep, push)
        assert same is reading  # under half a step: nothing to predict


def test_a_bad_reading_or_a_diverging_prediction_is_never_passed_off_as_a_prediction():
    # MuJoCo resets the data on a NaN or huge state: a finite qpos0 must not come back as "the prediction".
    controller = make_controller("cartpole", "ps", seed=0, num_workers=1)
    with controller:
        reading = MujocoSystem.from_task(controller.task, 0).read_state()
        predictor = LatencyPredictor(controller.task)
        nan = dataclasses.replace(reading, state=np.full_like(reading.state, np.nan))
        assert predictor.predict_reading(nan, 0.05, lambda now: np.zeros(1)) is nan  # the planner refuses it
        huge = dataclasses.replace(reading, state=np.full_like(reading.state, 1e300))
        assert predictor.predict_reading(huge, 0.05, lambda now: np.zeros(1)) is huge


def test_a_compensated_plan_starts_where_the_plant_will_be_when_it_takes_effect():
    config = ControllerConfig(horizon=0.5, control_freq=20.0, latency_compensation=True)
    controller = make_controller("cartpole", "ps", controller_config=config, seed=0, num_workers=1)
    with controller:
        loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, 0), latency=0.03)
        reading = loop.restart()
        plan = loop.plan(reading)
        assert plan is not None and plan.start_time == pytest.approx(reading.time + 0.03)
        controller.config = ControllerConfig(horizon=0.5, control_freq=20.0)
        assert loop.plan(reading).start_time == pytest.approx(reading.time)  # type: ignore[union-attr]


def test_compensation_keeps_a_cartpole_balanced_at_a_latency_that_topples_it_without():
    def balanced(compensate: bool) -> float:
        values = {"controller.latency_compensation": compensate, "controller.control_freq": 20.0}
        spec = EpisodeSpec("cartpole", "ps", 3.0, 0.025, values)
        return run_seeded_episode(spec, 0).metrics["balanced_fraction"]

    assert balanced(True) > balanced(False)
