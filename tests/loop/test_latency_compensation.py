"""Latency compensation: the reading predicted on the planning model to when the plan takes effect,
under the controls the plant gets meanwhile, is what the controller plans from (real MuJoCo physics,
cartpole)."""

import dataclasses

import numpy as np
import pytest

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import make_controller
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.loop.timing import LatencyPredictor


def test_the_prediction_is_the_plant_stepped_under_the_same_controls():
    controller = make_controller("cartpole", "ps", seed=0, num_workers=1)
    with controller:
        plant = MujocoSystem.from_task(controller.task, 0)
        reading = plant.read_state()
        push = lambda now, state: np.array([0.3 + now - 0.1 * state[0]])  # noqa: E731  (changes with time and state)
        predicted = LatencyPredictor(controller.task).predict_reading(reading, 0.05, push)
        for _ in range(round(0.05 / plant.timestep)):
            plant.apply(push(plant.task.data.time, plant.read_state().state))
            plant.step()
        truth = plant.read_state()
        assert predicted.time == pytest.approx(truth.time)
        np.testing.assert_allclose(predicted.state, truth.state, atol=1e-12)
        assert predicted.metadata is reading.metadata
        same = LatencyPredictor(controller.task).predict_reading(
            reading, 0.2 * plant.timestep, push
        )
        assert same is reading  # under half a step: nothing to predict


def test_a_bad_reading_or_a_diverging_prediction_is_never_passed_off_as_a_prediction():
    # MuJoCo resets the data on a NaN or huge state: a finite qpos0 must not come back as "the
    # prediction".
    controller = make_controller("cartpole", "ps", seed=0, num_workers=1)
    with controller:
        reading = MujocoSystem.from_task(controller.task, 0).read_state()
        predictor = LatencyPredictor(controller.task)
        nan = dataclasses.replace(reading, state=np.full_like(reading.state, np.nan))
        # the planner refuses it
        assert predictor.predict_reading(nan, 0.05, lambda now, state: np.zeros(1)) is nan
        huge = dataclasses.replace(reading, state=np.full_like(reading.state, 1e300))
        assert predictor.predict_reading(huge, 0.05, lambda now, state: np.zeros(1)) is huge


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


def test_a_plan_with_gains_takes_effect_where_its_nominal_starts(monkeypatch):
    # A latency between two plant steps: the plan takes effect at the later step, so its reading is
    # predicted that far, and with feedback it is planned from the prediction whatever
    # latency_compensation says. Each plan's first served state is then its nominal rollout's start,
    # and the gains correct nothing on a plant that is the model.
    from judo.core.feedback_plan import FeedbackPlan

    first_serves: dict[int, tuple[float, float, float]] = {}
    # Held so that no plan is freed and its id given to a later plan, which would go uncounted.
    plans_seen: list[FeedbackPlan] = []
    serve = FeedbackPlan.__call__

    def recording(plan, times, state=None):
        if state is not None and plan.gains is not None and id(plan) not in first_serves:
            step = round((float(times) - plan.start_time) / plan.model.opt.timestep)
            first_serves[id(plan)] = (
                float(times) - plan.start_time,
                step,
                float(np.abs(state - plan.nominal_states[step]).max()),
            )
            plans_seen.append(plan)
        return serve(plan, times, state)

    monkeypatch.setattr(FeedbackPlan, "__call__", recording)
    config = dataclasses.replace(
        ControllerConfig(), feedback=True, latency_compensation=False, control_freq=10.0
    )
    controller = make_controller(
        "cartpole", "mppi", controller_config=config, seed=0, num_workers=1
    )
    with controller:
        plant = MujocoSystem.from_task(controller.task, 0)
        loop = ClosedLoop(controller, plant, latency=2.5 * plant.timestep)
        loop.restart()
        for _ in range(round(1.0 / plant.timestep)):
            loop.step()
        # took effect at the next step
        assert loop.latency_s[-1] == pytest.approx(3 * plant.timestep)
    assert len(first_serves) >= 9  # a plan every 0.1 s for 1 s
    for age, step, deviation in first_serves.values():
        assert abs(age) < 1e-9 and step == 0
        assert deviation < 1e-9
