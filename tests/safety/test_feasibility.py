"""Planned within the limits: a rollout that crosses a hard limit never wins, whatever the
optimizer."""

import numpy as np
import pytest

from judo.core.configuration.registry import get_registered_optimizers, make_controller
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.safety.config import SafetyConfig
from judo.safety.feasibility import RolloutScreen
from judo.safety.limits import resolve
from judo.safety.serve_filter import safety_guard


def screen_of(task, **limits) -> RolloutScreen:
    return RolloutScreen(resolve(task, SafetyConfig(**limits)), task.dt, task.model.nq)


def test_the_screen_scores_infeasible_rows_minus_infinity_and_counts_an_iteration_without_a_feasible_one():  # noqa: E501
    controller = make_controller("cartpole", "ps", seed=0)
    screen = screen_of(controller.task, position=("slider=-1:1",), rate=("push=10",))
    states = np.zeros((3, 4, 4))
    states[1, 2, 0] = 1.5  # crosses the cart's limit at step 2
    controls = np.zeros((3, 4, 1))
    controls[2, 3, 0] = 0.5  # 0.5 in one step of 0.01 s: 50 per s, over the rate limit of 10
    rewards = screen.screen(
        np.array([-3.0, -1.0, -2.0]), states, np.zeros((3, 4, 0)), controls, np.zeros(1), 1
    )
    assert rewards.tolist() == [-3.0, -np.inf, -np.inf] and screen.no_feasible == 0
    states[0, 0, 0] = -1.25
    rewards = screen.screen(
        np.array([-3.0, -1.0, -2.0]), states, np.zeros((3, 4, 0)), controls, np.zeros(1), 1
    )
    assert rewards == pytest.approx([-0.25, -0.5, -(0.5 / 0.01 - 10)]) and screen.no_feasible == 1


@pytest.mark.parametrize("optimizer", list(get_registered_optimizers()))
def test_no_optimizer_chooses_an_infeasible_rollout_when_a_feasible_one_exists(optimizer):
    controller = make_controller("cartpole", optimizer, seed=1)
    loop = ClosedLoop(
        controller,
        MujocoSystem.from_task(controller.task, seed=1),
        guard=safety_guard(controller, SafetyConfig(position=("slider=-0.3:0.3",))),
    )
    screen = controller.limits
    assert isinstance(screen, RolloutScreen)
    state = np.array([0.2, np.pi, 1.0, 0.0])  # moving toward the limit: many samples cross it
    checked = 0
    for step in range(3):
        controller.update_action(state, 0.02 * step)
        infeasible = screen.last_infeasible
        if infeasible.any() and not infeasible.all():
            assert np.all(controller.rewards[infeasible] == -np.inf)
            assert not infeasible[int(np.argmax(controller.rewards))]
            checked += 1
    assert screen.iterations >= 3 and checked >= 1
    loop.controller.close()


def test_the_plan_predictive_sampling_serves_is_a_feasible_sample():
    controller = make_controller("cartpole", "ps", seed=2)
    ClosedLoop(
        controller,
        MujocoSystem.from_task(controller.task, seed=2),
        guard=safety_guard(controller, SafetyConfig(position=("slider=-0.3:0.3",))),
    )
    state = np.array([0.1, np.pi, 0.5, 0.0])  # three in four samples cross the limit
    controller.update_action(state, 0.0)
    feasible = ~controller.limits.last_infeasible
    assert feasible.any() and not feasible.all()
    # from its own plan: the nominal is the best sample, which kept the limit
    controller.update_action(state, 0.0)
    best = int(np.argmax(controller.rewards))
    assert feasible.any() and not controller.limits.last_infeasible[best]
    controller.close()


def test_a_start_beyond_a_limit_is_counted_and_planned_back_toward_it():
    controller = make_controller("cartpole", "ps", seed=3)
    ClosedLoop(
        controller,
        MujocoSystem.from_task(controller.task, seed=3),
        guard=safety_guard(controller, SafetyConfig(position=("slider=-0.3:0.3",))),
    )
    # already beyond: no sample keeps the limit
    controller.update_action(np.array([0.6, np.pi, 0.0, 0.0]), 0.0)
    assert controller.limits.no_feasible == controller.iterations_run >= 1
    assert np.isfinite(controller.rewards).all()  # ranked by how far each sample goes beyond
    controller.close()


def test_the_rate_limits_first_step_is_checked_against_the_command_the_filter_served_last():
    controller = make_controller("cartpole", "ps", seed=0)
    screen = screen_of(controller.task, rate=("push=10",))
    arrays = (np.zeros((1, 3, 4)), np.zeros((1, 3, 0)), np.full((1, 3, 1), 0.5))
    # the plan in force: no jump
    assert screen.violations(*arrays, np.array([0.5])).tolist() == [0.0]
    screen.last_served = np.array([0.0])  # what the serve filter set: a jump of 0.5 in 0.01 s
    assert screen.violations(*arrays, np.array([0.5])) == pytest.approx([0.5 / 0.01 - 10])
    controller.close()
