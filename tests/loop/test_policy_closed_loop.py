"""A policy as the controller, served through the one closed loop: its action held, its chunk served
as a plan, the watchdog's safe action when it raises or returns NaN, the fit check at construction,
and an MPC expert labelling the states it visits. Hand-written policies (numpy subclasses of
judo.Policy); no mocks."""

import numpy as np
import pytest
from slider_task import hold_base

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.controller import Controller
from judo.core.policies.policy_controller import PolicyController, make_policy_controller
from judo.core.policy import Policy, PolicyError
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


@pytest.fixture
def hold_task_cls(tmp_path):
    """A block on a rail with a position actuator; the reward wants the block at 0.5."""

    class Hold(hold_base(tmp_path)):
        def reset(self):
            self.data.qpos[:] = 0.3
            self.data.qvel[:] = 0.0

    return Hold


class Linear(Policy):
    """actions = observations @ weight.T + bias, as (B, horizon, nu) chunks; `fault` from
    `fault_after` s of the clock it is given: "raise" or "nan"."""

    def __init__(self, weight, bias, horizon=1, metadata=None):
        self.weight, self.bias = np.atleast_2d(weight), np.asarray(bias, float)
        self.observation_size, self.horizon = self.weight.shape[1], horizon
        self.action_size = self.weight.shape[0] // horizon
        self.metadata = metadata or {}
        self.calls: list[np.ndarray] = []
        self.fault, self.clock = None, None

    def act(self, observations):
        self.calls.append(np.array(observations))
        if self.fault is not None and self.clock() >= 0.5:
            if self.fault == "raise":
                raise RuntimeError("the policy's inference server is down")
            return np.full((len(observations), self.horizon, self.action_size), np.nan)
        return (observations @ self.weight.T + self.bias).reshape(
            len(observations), self.horizon, self.action_size
        )


def test_an_action_policy_is_held_between_updates_and_sees_the_state_it_was_served(hold_task_cls):
    """At 20 Hz on a 100 Hz plant: each update acts once on [qpos, qvel] of the reading, and the
    plant gets exactly that action until the next update."""
    policy = Linear([[0.5, -0.1]], [0.25])
    controller = PolicyController(hold_task_cls(), policy, ControllerConfig(control_freq=20.0))
    loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0))
    loop.restart()
    served, readings = [], []
    for _ in range(40):
        readings.append(loop.reading.state.copy())
        served.append(loop.step().action[0])
    assert len(policy.calls) == len(loop.update_ms) == 8 and all(
        call.shape == (1, 2) for call in policy.calls
    )
    for update, observation in enumerate(policy.calls):
        # the default observation: the state
        np.testing.assert_array_equal(observation[0], readings[5 * update])
        expected = observation[0] @ policy.weight[0] + 0.25
        assert served[5 * update : 5 * update + 5] == [pytest.approx(expected, abs=1e-15)] * 5
    assert controller.rewards.shape == (0,) and len(controller.inference_ms) == 8


def test_a_chunk_is_the_plan_until_the_next_inference_and_the_task_chooses_the_observation(
    hold_task_cls,
):
    """A 3-action chunk is the knots of a linear plan over the horizon; the task's observation
    (sensor and the previous action) is what the policy sees."""

    class Observed(hold_task_cls):
        def policy_observation(
            self, states, sensors=None, system_metadata=None, previous_actions=None
        ):
            # (B, 1 + 1): the jointpos sensor, the action
            return np.concatenate([sensors, previous_actions], axis=1)

    policy = Linear(np.array([[1.0, 0.0], [1.0, 0.5], [1.0, 1.0]]), [0.1, 0.2, 0.3], horizon=3)
    config = ControllerConfig(control_freq=10.0, horizon=0.2, spline_order="linear")
    controller = PolicyController(Observed(), policy, config)
    assert controller.task.policy_observation_size() == 2
    loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0))
    reading = loop.restart()
    plan = loop.plan(reading)
    x = reading.state[0]
    np.testing.assert_allclose(policy.calls[0], [[x, 0.0]])  # the warm start (0) was in force
    np.testing.assert_allclose(plan.knots[:, 0], [x + 0.1, x + 0.2, x + 0.3])
    np.testing.assert_allclose(plan.knot_times, reading.time + np.array([0.0, 0.1, 0.2]))
    # halfway between the first two knots
    assert loop.serve(reading.time + 0.05)[0] == pytest.approx(x + 0.15)
    loop.advance()
    held = controller.action(loop.reading.time)[0]
    loop.plan(loop.reading)
    assert policy.calls[1][0, 1] == pytest.approx(held)  # the previous action: the plan in force


@pytest.mark.parametrize("fault", ["nan", "raise"])
def test_the_watchdog_serves_the_safe_action_when_the_policy_fails_and_resumes(
    hold_task_cls, fault
):
    """A policy that fails from t = 0.5 s: within max_plan_age + one period the plant gets
    safe_action (hold the block where it is); when the policy works again, its actions are served
    again."""
    events = []
    policy = Linear([[0.0, 0.0]], [0.5])
    config = ControllerConfig(control_freq=20.0, max_plan_age=0.2)
    controller = PolicyController(hold_task_cls(), policy, config)
    loop = ClosedLoop(
        controller, MujocoSystem.from_task(controller.task, seed=0), on_watchdog=events.append
    )
    policy.fault, policy.clock = fault, lambda: loop.stepped_time
    loop.restart()
    served = []  # (time after the step, action served, position before the step, watchdog tripped)
    for _ in range(150):
        before = loop.reading.state[0]
        try:
            record = loop.step()
        except RuntimeError:  # the raising policy: the loop's caller (the app, evaluate) reports it
            record = loop.advance()
        served.append((record.time, record.action[0], before, loop.watchdog.tripped is not None))
        if record.time >= 1.2:
            policy.clock = lambda: -1.0  # the fault clears
    tripped = [row for row in served if row[3]]
    assert loop.watchdog.trips == 1 and "plan in force is" in events[0] and events[-1] is None
    first_time, first_action, position, _ = tripped[0]
    assert 0.5 < first_time <= 0.5 + 0.2 + 0.05 + 0.011
    # safe_action: the position servo holds the block where it is
    assert first_action == pytest.approx(position)
    assert all(row[1] == pytest.approx(row[2]) for row in tripped)
    # the policy's action otherwise
    assert all(row[1] == pytest.approx(0.5) for row in served if not row[3])
    assert not served[-1][3] and loop.watchdog.tripped is None
    if fault == "nan":
        assert loop.failed_updates >= 10 and "returned non-finite actions" in str(loop.last_failure)


def test_a_policy_for_another_task_or_observation_is_refused_in_one_line_at_construction(
    hold_task_cls,
):
    with pytest.raises(PolicyError) as err:
        PolicyController(
            hold_task_cls(),
            Linear([[1.0, 0.0]], [0.0], metadata={"task": "cartpole"}),
            task_name="hold",
        )
    assert str(err.value) == "policy 'Linear' was made for task 'cartpole', not 'hold'"
    with pytest.raises(PolicyError) as err:
        PolicyController(hold_task_cls(), Linear([[1.0, 0.0, 0.0]], [0.0]), task_name="hold")
    assert str(err.value) == (
        "policy 'Linear' takes observations of size 3, but the task hold gives 2"
    )
    with pytest.raises(PolicyError, match="chunks of 3 actions, but a cubic plan needs at least 4"):
        PolicyController(
            hold_task_cls(),
            Linear(np.ones((3, 2)), np.zeros(3), 3),
            ControllerConfig(spline_order="cubic"),
        )
    with pytest.raises(PolicyError) as err:
        make_policy_controller("cartpole", Linear([[1.0, 0.0]], [0.0]))
    assert str(err.value) == (
        "policy 'Linear' takes observations of size 2, but the task cartpole gives 5"
    )


def test_the_policys_metadata_sets_the_rate_and_code_wins():
    policy = Linear(np.zeros((1, 5)), [0.0], metadata={"task": "cartpole", "control_freq": "50"})
    with make_policy_controller("cartpole", policy) as controller:
        assert controller.config.control_freq == 50.0
    with make_policy_controller(
        "cartpole", policy, controller_config=ControllerConfig(control_freq=25.0)
    ) as c:
        assert c.config.control_freq == 25.0
    bad = Linear(np.zeros((1, 5)), [0.0], metadata={"control_freq": "fast"})
    with pytest.raises(PolicyError, match="metadata control_freq='fast' is not a number"):
        make_policy_controller("cartpole", bad)


def test_an_expert_plans_from_every_state_the_policy_is_served_from(hold_task_cls):
    task = hold_task_cls()
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=2, sigma=0.3), nu=1
    )
    optimizer.rng = np.random.default_rng(0)
    expert = Controller(
        ControllerConfig(horizon=0.1, control_freq=20.0), task, optimizer, num_workers=1
    )
    policy = Linear([[0.0, 0.0]], [-1.0])
    with PolicyController(task, policy, expert=expert) as controller:
        assert controller.config.horizon == 0.1 and controller.config is not expert.config
        loop = ClosedLoop(controller, MujocoSystem.from_task(task, seed=0))
        loop.restart()
        for _ in range(30):
            record = loop.step()
            assert record.action[0] == pytest.approx(-1.0)  # the policy drives
        assert expert.nominal_knots is not None and controller.rewards.shape == (8,)
        assert np.all(expert.nominal_knots > -1.0)  # the MPC wants the block at 0.5, not at -1


@pytest.mark.parametrize("fixed_batch", [False, True])
def test_an_onnx_chunk_policy_is_served_through_the_loop_as_its_matrix_product(
    hold_task_cls, tmp_path, fixed_batch
):
    """A chunk policy file (3 knots of W o + b; fixed batch 1 or dynamic) on onnxruntime, made for
    the task at 10 Hz: each plan's knots are the product (to float32), and the plant gets the linear
    plan between them."""
    pytest.importorskip("onnxruntime")
    from judo.core.policies.onnx_policy import write_linear_policy

    weight, bias = np.array([[1.0, 0.0], [0.5, 0.1], [0.0, 0.2]]), np.array([0.0, 0.1, 0.2])
    metadata = {"task": "hold", "control_freq": "10", "horizon": "0.2", "spline_order": "linear"}
    path = write_linear_policy(
        tmp_path / "chunk.onnx", weight, bias, metadata, fixed_batch, horizon=3
    )
    with make_policy_controller_for(hold_task_cls, path) as controller:
        assert (controller.config.control_freq, controller.config.horizon) == (10.0, 0.2)
        loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0))
        loop.restart()
        for _ in range(30):
            state, now = loop.reading.state.copy(), loop.reading.time
            planned = len(loop.update_ms)
            record = loop.step()
            if len(loop.update_ms) > planned:  # this step planned from `state`
                expected, planned_at = weight @ state + bias, now
                np.testing.assert_allclose(
                    controller.nominal_knots[:, 0], expected, rtol=1e-6, atol=1e-6
                )
                # the plan at its start
                assert record.action[0] == pytest.approx(controller.nominal_knots[0, 0])
        assert len(loop.update_ms) == 3 and loop.failed_updates == 0
        assert loop.serve(planned_at + 0.05)[0] == pytest.approx(
            np.mean(controller.nominal_knots[:2, 0])
        )


def make_policy_controller_for(task_cls, path):
    from judo.core.policies.policy_controller import as_policy, policy_config

    policy = as_policy(path)
    return PolicyController(task_cls(), policy, policy_config(policy), task_name="hold")
