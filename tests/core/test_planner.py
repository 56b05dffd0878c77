"""Both planners, the optimizer's Controller and the PolicyController, satisfy the one `Planner`
contract the closed loop types against, and the `PlannerView` the app reads (they answer their kind,
config kinds and cycle size instead of being branched on); a class missing part of it does not; and
both refuse a bad reading with the one shared check. Real controllers on the registered
cart-pole."""

import math
from collections.abc import Iterator

import numpy as np
import pytest

import judo
from judo.core.controller import Controller
from judo.core.errors import ConfigError, JudoError
from judo.core.planner import Planner
from judo.core.planner_view import AppPlanner, CycleSize, PlannerKind, PlannerView
from judo.core.policies.policy_controller import PolicyController, make_policy_controller
from judo.core.policy import Policy
from judo.core.reading import checked_reading
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.optimizers.ps import PredictiveSamplingConfig


class Push(Policy):
    """Pushes the cart with a constant action of 0.3, whatever it sees."""

    observation_size, action_size, horizon = 5, 1, 1

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), 1, 1), 0.3)


@pytest.fixture
def controller() -> Iterator[Controller]:
    config, optimizer_config = (
        judo.ControllerConfig(horizon=0.2, max_opt_iters=1),
        PredictiveSamplingConfig(num_rollouts=8),
    )
    made = judo.make_controller(
        "cartpole", "ps", controller_config=config, optimizer_config=optimizer_config, num_workers=1
    )
    with made:
        yield made


@pytest.fixture
def policy_controller() -> Iterator[PolicyController]:
    with make_policy_controller("cartpole", Push()) as made:
        yield made


def test_both_planners_satisfy_the_contract_and_report_what_they_have(
    controller: Controller, policy_controller: PolicyController
):
    # pyright checks both against the protocol
    planners: list[Planner] = [controller, policy_controller]
    assert all(isinstance(planner, Planner) for planner in planners)
    assert controller.optimizer is not None and controller.backend_name == "cpu"
    assert controller.backend is not None and controller.backend.num_workers == 1
    assert policy_controller.optimizer is None and policy_controller.backend is None
    assert policy_controller.backend_name is None and policy_controller.proposal_policy is None
    # before any update
    assert policy_controller.iterations_run == 0 and controller.iterations_run == 0


PLANNER_MEMBERS = {
    "config",
    "task",
    "update_action",
    "action",
    "warm_start_action",
    "reset",
    "close",
}


def test_the_loop_contract_holds_only_what_the_loop_calls_and_the_view_the_rest():
    members = {
        name for name in [*dir(Planner), *Planner.__annotations__] if not name.startswith("_")
    }
    assert members == PLANNER_MEMBERS
    view = {
        name
        for name in [*dir(PlannerView), *PlannerView.__annotations__]
        if not name.startswith("_")
    }
    assert (
        not view & PLANNER_MEMBERS
        and {"kind", "rewards", "traces", "backend", "iterations_run"} <= view
    )


def test_both_planners_answer_what_the_app_asks(
    controller: Controller, policy_controller: PolicyController
):
    planners: list[AppPlanner] = [controller, policy_controller]
    assert all(
        isinstance(planner, PlannerView) and isinstance(planner, AppPlanner) for planner in planners
    )
    assert (controller.kind, policy_controller.kind) == (PlannerKind.MPC, PlannerKind.POLICY)
    assert (
        PlannerKind.of_choice("policy") is PlannerKind.POLICY
        and PlannerKind.of_choice("mppi") is PlannerKind.MPC
    )
    assert (
        controller.config_kinds
        == tuple(controller.configs())
        == ("controller", "optimizer", "task")
    )
    assert (
        policy_controller.config_kinds
        == tuple(policy_controller.configs())
        == ("controller", "task")
    )
    assert controller.cycle_size(controller.configs()) == CycleSize(
        8, 1, controller.config.iterations_per_cycle, 20
    )
    # a policy rolls nothing out
    assert policy_controller.cycle_size(policy_controller.configs()) is None
    assert (
        "policy_samples" not in controller.controller_fields
        and "horizon" in controller.controller_fields
    )
    assert "num_randomizations" not in policy_controller.controller_fields
    with pytest.raises(
        ConfigError, match="policy_samples is 2 but the controller has no proposal policy"
    ):
        configs = controller.configs()
        controller.check_configs(
            {**configs, "controller": judo.ControllerConfig(horizon=0.2, policy_samples=2)}
        )


def test_an_update_runs_its_phases_in_order(controller: Controller, monkeypatch):
    ran: list[str] = []
    for phase in (
        "_begin",
        "_sample",
        "_clamp",
        "_roll_out",
        "_score_rollouts",
        "_update",
        "_publish",
    ):
        inner = getattr(controller, phase)

        def recorded(*args, _inner=inner, _phase=phase):
            ran.append(_phase)
            return _inner(*args)

        monkeypatch.setattr(controller, phase, recorded)
    controller.update_action(np.zeros(4), 0.0)
    iteration = ["_sample", "_clamp", "_roll_out", "_score_rollouts", "_update"]
    assert ran == ["_begin", *iteration * controller.iterations_run, "_publish"]


def test_a_class_missing_part_of_the_contract_is_not_a_planner(controller):
    class NoWarmStart:
        """Everything a Planner has but `warm_start_action`."""

        def __init__(self, inner: Controller) -> None:
            self.config, self.task, self.nominal_knots = inner.config, inner.task, None
            self.rewards, self.traces, self.optimizer = inner.rewards, inner.traces, inner.optimizer
            self.backend, self.backend_name, self.proposal_policy = (
                inner.backend,
                inner.backend_name,
                None,
            )
            self.iterations_run = 0
            self.update_action, self.action = inner.update_action, inner.action
            self.reset, self.close = inner.reset, inner.close

    class Whole(NoWarmStart):
        def warm_start_action(self, state: np.ndarray | None = None) -> np.ndarray:
            return np.zeros(1)

    assert not isinstance(NoWarmStart(controller), Planner)
    assert isinstance(Whole(controller), Planner)  # the missing member makes it one


@pytest.mark.parametrize("make", ["controller", "policy_controller"])
def test_either_planner_drives_the_one_closed_loop(make, request):
    planner: Planner = request.getfixturevalue(make)
    loop = ClosedLoop(planner, MujocoSystem.from_task(planner.task, seed=0))
    loop.restart()
    records = [loop.step() for _ in range(10)]
    actions = [record.action[0] for record in records if record is not None]
    assert len(actions) == 10
    assert len(loop.update_ms) >= 1 and planner.nominal_knots is not None
    assert all(np.isfinite(actions))
    if make == "policy_controller":
        assert actions[-1] == pytest.approx(0.3, abs=1e-15)


@pytest.mark.parametrize(
    ("make", "doing"), [("controller", "plan from"), ("policy_controller", "act on")]
)
def test_both_refuse_a_bad_reading_with_the_one_check_and_keep_their_plan(make, doing, request):
    planner: Planner = request.getfixturevalue(make)
    planner.update_action(np.zeros(4), 0.0)
    knots = planner.nominal_knots
    with pytest.raises(
        JudoError,
        match=rf"^cannot {doing} a non-finite reading "
        r"\(non-finite state entries \[1\]\)",
    ):
        planner.update_action(np.array([0.0, math.nan, 0.0, 0.0]), 0.1)
    with pytest.raises(
        JudoError,
        match=rf"^cannot {doing} a non-finite "
        r"reading \(non-finite time inf\)",
    ):
        planner.update_action(np.zeros(4), math.inf)
    with pytest.raises(
        ConfigError,
        match=r"^state must have shape \(4,\) "
        r"= \(nq \+ nv,\), got \(3,\)$",
    ):
        planner.update_action(np.zeros(3), 0.2)
    assert planner.nominal_knots is knots


def test_the_check_returns_the_state_as_floats():
    state = checked_reading([1, 2], 0.0, 2, "plan from")
    assert state.dtype == float and state.tolist() == [1.0, 2.0]


@pytest.mark.parametrize("make", ["controller", "policy_controller"])
def test_the_plan_carries_what_the_loop_records_and_a_policy_keeps_feedback_off(make, request):
    planner: AppPlanner = request.getfixturevalue(make)
    planner.config = judo.ControllerConfig(horizon=0.2, max_opt_iters=1, feedback=True)
    loop = ClosedLoop(planner, MujocoSystem.from_task(planner.task, seed=0))
    assert loop.predicts() is (make == "controller")  # gains only on an optimizer's plans
    assert planner.config.feedback is (make == "controller")
    plan = planner.update_action(loop.restart().state, 0.0)
    assert np.array_equal(plan.rewards, planner.rewards) and np.array_equal(
        plan.traces, planner.traces
    )
    assert plan.rewards.shape == ((8,) if make == "controller" else (0,))
