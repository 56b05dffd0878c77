"""The policy as a proposal (ControllerConfig.policy_samples), for all six optimizers, on real
MuJoCo rollouts.

"Never worse" is checked in this precise sense: the same seed's update with and without K proposals
ranks the same N - K other candidates (the same knots and the same rewards, bit for bit, the nominal
row 0 among them), so the best reward of the update with proposals is at least the best among those.
It holds by construction: the proposals overwrite the last K rows after the optimizer sampled, and
draw nothing from its generator.
"""

import numpy as np
import pytest

import judo
from judo.core.configuration.registry import lookup_optimizer
from judo.core.policies.proposals import chunk_to_knots, fit_matrix, fit_times
from judo.core.spline import SplineBasis
from judo.optimizers.cmaes import CMAES, CMAESConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig
from tests.conftest import UprightTask

OPTIMIZERS = ["ps", "cem", "mppi", "dial", "cmaes", "icem"]
NUM_ROLLOUTS, NUM_NODES, HORIZON = 16, 4, 0.3

CLOCK_XML = """
<mujoco>
  <option timestep="0.01" gravity="0 0 0" integrator="Euler"/>
  <worldbody>
    <body name="clock"><joint name="clock" type="slide" axis="1 0 0"/>
      <geom type="sphere" size=".1" mass="1" contype="0" conaffinity="0"/></body>
    <body name="mass"><joint name="push" type="slide" axis="0 1 0"/>
      <geom type="sphere" size=".1" mass="1" contype="0" conaffinity="0"/></body>
  </worldbody>
  <actuator><motor joint="push" ctrlrange="-5 5"/></actuator>
</mujoco>
"""
"""A body sliding at 1 m/s with nothing acting on it, so its qpos is the time, and a pushed mass."""


class RandomPolicy(judo.Policy):
    """Uniform actions in [-2, 2] (beyond the ctrlrange, so the clamp matters), from its own
    generator."""

    def __init__(self, horizon: int, observation_size: int = 4, seed: int = 7) -> None:
        self.observation_size, self.action_size, self.horizon = observation_size, 1, horizon
        self.metadata = {}
        self.rng = np.random.default_rng(seed)

    def act(self, observations):
        return self.rng.uniform(-2.0, 2.0, (len(observations), self.horizon, self.action_size))


class ConstantPolicy(judo.Policy):
    """The same action everywhere: a chunk of `horizon` copies of `value`."""

    def __init__(self, value: float, horizon: int, observation_size: int = 4) -> None:
        self.observation_size, self.action_size, self.horizon = observation_size, 1, horizon
        self.metadata = {"name": "constant"}
        self.value = value

    def act(self, observations):
        return np.full((len(observations), self.horizon, 1), self.value)


class TrackTask(UprightTask):
    """Its best plan is known: every control at TARGET."""

    TARGET = 0.37

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -np.square(controls - self.TARGET).sum((-1, -2))


def make(task, optimizer, samples=0, policy=None, seed=0, **controller_fields):
    optimizer_cls, config_cls = lookup_optimizer(optimizer)
    opt = optimizer_cls(config_cls(num_rollouts=NUM_ROLLOUTS, num_nodes=NUM_NODES), task.nu)
    opt.rng = np.random.default_rng(seed)
    config = judo.ControllerConfig(horizon=HORIZON, policy_samples=samples, **controller_fields)
    return judo.Controller(config, task, opt, num_workers=1, proposal_policy=policy)


def update(controller, state=None):
    state = np.array([0.0, 0.4, 0.0, 0.0]) if state is None else state
    with controller:
        controller.update_action(state, 0.0)
        return (
            controller.rewards.copy(),
            controller.batch_controls.copy(),
            controller.nominal_knots.copy(),
        )


@pytest.mark.parametrize("horizon", [1, NUM_NODES], ids=["action", "chunk"])
@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_random_proposals_never_make_an_update_worse(tiny_model_path, optimizer, horizon):
    k = 5
    without, _, _ = plain = update(make(UprightTask(tiny_model_path), optimizer))
    rewards, controls, _ = update(
        make(UprightTask(tiny_model_path), optimizer, k, RandomPolicy(horizon))
    )
    kept = NUM_ROLLOUTS - k
    # the same draws, the nominal row 0 among them
    np.testing.assert_array_equal(controls[:kept], plain[1][:kept])
    np.testing.assert_array_equal(rewards[:kept], without[:kept])
    assert not np.array_equal(controls[kept:], plain[1][kept:])  # the policy's, not the optimizer's
    assert np.abs(controls).max() <= 1.0  # clamped like the optimizer's own
    assert rewards.max() >= without[:kept].max()


@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_a_policy_that_proposes_the_optimum_is_picked(tiny_model_path, optimizer):
    target = TrackTask.TARGET
    _, _, plain = update(make(TrackTask(tiny_model_path), optimizer))
    policy = ConstantPolicy(target, NUM_NODES)
    rewards, _, nominal = update(make(TrackTask(tiny_model_path), optimizer, 3, policy))
    # the policy's own candidate; the two after it carry noise
    assert np.argmax(rewards) == NUM_ROLLOUTS - 3
    assert rewards.max() > -1e-30  # 0 up to the rounding of the spline weights
    if optimizer in ("ps", "cmaes", "icem"):  # they plan with their best sample
        np.testing.assert_array_equal(nominal, np.full((NUM_NODES, 1), target))
    else:  # averages of the samples: pulled towards it
        assert np.abs(nominal - target).max() < np.abs(plain - target).max()


@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_every_optimizer_runs_with_all_but_the_nominal_replaced(tiny_model_path, optimizer):
    controller = make(
        UprightTask(tiny_model_path), optimizer, NUM_ROLLOUTS - 1, RandomPolicy(1), max_opt_iters=2
    )
    with controller:
        for step in range(3):
            controller.update_action(np.array([0.0, 0.4, 0.0, 0.0]), 0.05 * step)
            assert (
                np.isfinite(controller.nominal_knots).all()
                and np.abs(controller.nominal_knots).max() <= 1.0
            )


def test_an_action_policy_with_a_constant_action_is_fitted_to_constant_knots(tiny_model_path):
    _, controls, nominal = update(
        make(TrackTask(tiny_model_path), "ps", 1, ConstantPolicy(TrackTask.TARGET, 1))
    )
    np.testing.assert_allclose(controls[-1], TrackTask.TARGET, rtol=0, atol=1e-12)
    np.testing.assert_allclose(nominal, TrackTask.TARGET, rtol=0, atol=1e-12)


class CountingPolicy(RandomPolicy):
    """RandomPolicy, counting the rows it is asked to act on; `deterministic` as told."""

    def __init__(self, deterministic: bool) -> None:
        super().__init__(1)
        self.deterministic, self.rows = deterministic, 0

    def act(self, observations):
        self.rows += len(observations)
        return super().act(observations)


def test_a_deterministic_policy_rolls_out_one_candidate_and_a_sampling_one_all_of_them(
    tiny_model_path,
):
    import mujoco

    from judo.core.model import STATE_SPEC
    from judo.core.policies.proposals import Proposer

    task = TrackTask(tiny_model_path)
    state = np.zeros(mujoco.mj_stateSize(task.model, STATE_SPEC))
    basis = SplineBasis(np.linspace(0.0, HORIZON, NUM_NODES), "linear")
    made = {}
    for deterministic in (False, True):
        policy = CountingPolicy(deterministic)
        candidates = Proposer(task, policy, 3).candidates(
            policy, 3, state, np.zeros(0), basis, 30, None, np.zeros(task.nu)
        )
        made[deterministic] = (candidates, policy.rows)
    sampled, rows_sampled = made[False]
    repeated, rows_repeated = made[True]
    assert sampled.shape == repeated.shape == (3, NUM_NODES, task.nu)
    assert not np.allclose(sampled[0], sampled[1])  # three draws of its own
    np.testing.assert_array_equal(repeated[0], repeated[1])
    np.testing.assert_array_equal(repeated[1], repeated[2])
    assert rows_sampled == 3 * rows_repeated > 0


@pytest.mark.parametrize("order", ["zero", "linear", "cubic"])
def test_the_least_squares_fit_reproduces_knots_whose_spline_gives_the_actions(order):
    basis = SplineBasis(np.linspace(0.0, HORIZON, 5), order)
    knots = np.random.default_rng(0).normal(size=(5, 2))
    # (T + 1, nu), in the spline's span
    actions = basis.weights(fit_times(30, 0.01, HORIZON)) @ knots
    np.testing.assert_allclose(fit_matrix(basis, 30, 0.01) @ actions, knots, rtol=0, atol=1e-10)


class ClockSplinePolicy(judo.Policy):
    """An action policy that reads the time off the clock body and plays a spline: its actions lie
    in the span."""

    def __init__(self, basis: SplineBasis, knots: np.ndarray) -> None:
        self.observation_size, self.action_size, self.horizon = 4, 1, 1
        self.metadata = {}
        self.basis, self.knots = basis, knots

    def act(self, observations):
        return (self.basis.weights(observations[:, 0]) @ self.knots)[:, None, :]


@pytest.mark.parametrize("order", ["zero", "linear", "cubic"])
def test_an_action_policy_rolled_out_in_closed_loop_is_fitted_exactly(tmp_path, order):
    path = tmp_path / "clock.xml"
    path.write_text(CLOCK_XML)
    knot_offsets = np.linspace(0.0, HORIZON, 5)
    knots = np.array([[0.5], [-1.0], [2.0], [0.25], [-3.0]])
    policy = ClockSplinePolicy(SplineBasis(knot_offsets, order), knots)
    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=4, num_nodes=5), 1)
    config = judo.ControllerConfig(horizon=HORIZON, spline_order=order, policy_samples=1)
    task = UprightTask(path)
    with judo.Controller(
        config, task, optimizer, num_workers=1, proposal_policy=policy
    ) as controller:
        controller.update_action(np.array([0.0, 0.0, 1.0, 0.0]), 0.0)  # the clock moving at 1 m/s
        weights = SplineBasis(knot_offsets, order).weights(
            np.arange(controller.num_steps) * task.dt
        )
        expected = np.clip(weights @ knots, -5, 5)
        np.testing.assert_allclose(controller.batch_controls[-1], expected, rtol=0, atol=1e-9)


def test_a_chunk_of_another_length_is_resampled_onto_the_knot_times():
    chunk = np.array([[[0.0], [1.0], [2.0]]])  # 3 values evenly over the horizon: a ramp
    knots = chunk_to_knots(chunk, np.linspace(0.0, HORIZON, 5))
    np.testing.assert_allclose(knots[0, :, 0], [0.0, 0.5, 1.0, 1.5, 2.0])
    assert chunk_to_knots(chunk, np.linspace(0.0, HORIZON, 3)) is chunk


def test_cmaes_takes_a_proposal_as_an_injected_solution():
    cmaes = CMAES(CMAESConfig(num_rollouts=8, num_nodes=3), 2)
    cmaes.rng = np.random.default_rng(0)
    knots = cmaes.sample_control_knots(np.zeros((3, 2)))
    near = knots[1] + 0.01
    far = np.full((3, 2), 100.0)
    cmaes.samples_replaced(np.array([6, 7]), np.stack([near, far]))
    step = cmaes.step_size * np.sqrt(cmaes.variances)
    # its own draw now
    np.testing.assert_allclose(cmaes.mean + step * cmaes._draws[5], near.ravel(), atol=1e-12)
    n = 6
    # clipped length
    assert np.linalg.norm(cmaes._draws[6]) == pytest.approx(np.sqrt(n) + 2 * n / (n + 2))
    assert np.all(cmaes._draws[6] > 0)  # pointing at it


def test_policy_samples_errors(tiny_model_path):
    task = UprightTask(tiny_model_path)
    with pytest.raises(
        judo.ConfigError,
        match=r"^policy_samples must be between "
        r"0 and 1048575 \(0: off\), got -1$",
    ):
        judo.ControllerConfig(policy_samples=-1)
    with pytest.raises(
        judo.ConfigError,
        match=r"^policy_samples \(16\) must be below num_rollouts \(16\): the nominal, rollout 0, "
        r"is never replaced; "
        r"expected 0 to 15$",
    ):
        make(task, "ps", 16, ConstantPolicy(0.0, 1))
    message = (
        r"^policy_samples is 2 but the controller has no proposal policy; give one "
        r"\(make_controller\(\.\.\., "
        r"proposal_policy=\.\.\.\), evaluate --proposal-policy FILE\.onnx\) or set it to 0$"
    )
    with pytest.raises(judo.ConfigError, match=message):
        make(task, "ps", 2)
    controller = make(task, "ps")
    controller.config.policy_samples = 2  # as the GUI's slider edits it
    with controller, pytest.raises(judo.ConfigError, match=message):
        controller.update_action(np.zeros(4), 0.0)
    with pytest.raises(
        judo.PolicyError,
        match=r"^policy 'constant' takes observations "
        r"of size 3, but the task \? gives 4$",
    ):
        make(task, "ps", 1, ConstantPolicy(0.0, 1, observation_size=3))


def test_make_controller_names_the_task_a_policy_was_not_made_for():
    policy = ConstantPolicy(0.0, 1, observation_size=5)  # cartpole's size: only the task is wrong
    policy.metadata["task"] = "acrobot"
    with pytest.raises(
        judo.PolicyError,
        match=r"^policy 'constant' was made for "
        r"task 'acrobot', not 'cartpole'$",
    ):
        judo.make_controller("cartpole", "ps", proposal_policy=policy)


def test_a_failing_policy_costs_the_update_its_proposals_not_its_plan(tiny_model_path):
    policy = ConstantPolicy(np.nan, 1)
    controller = make(UprightTask(tiny_model_path), "ps", 3, policy)
    plain = update(make(UprightTask(tiny_model_path), "ps"))
    with pytest.warns(
        RuntimeWarning,
        match="this update runs without proposals: policy 'constant' returned non-finite",
    ):
        rewards, controls, _ = update(controller)
    np.testing.assert_array_equal(controls, plain[1])  # the optimizer's own N samples
    assert controller._proposer.last_error == "policy 'constant' returned non-finite actions"


class ObservedTask(UprightTask):
    """A task with its own policy observation: the state and the previous action (O = nq + nv +
    nu)."""

    def policy_observation(self, states, sensors, system_metadata=None, previous_actions=None):
        return np.concatenate([states, previous_actions], axis=1)


class RampPolicy(judo.Policy):
    """Its previous action plus 0.01: a ramp in time, which a linear spline follows exactly."""

    def __init__(self) -> None:
        self.observation_size, self.action_size, self.horizon = 5, 1, 1
        self.metadata = {}

    def act(self, observations):
        return observations[:, None, 4:5] + 0.01


def test_the_task_s_policy_observation_gets_the_previous_action(tiny_model_path):
    with make(ObservedTask(tiny_model_path), "ps", 1, RampPolicy()) as controller:
        controller.update_action(np.array([0.0, 0.4, 0.0, 0.0]), 0.0)  # the warm start serves 0 now
        times = np.arange(controller.num_steps) * controller.task.dt
        np.testing.assert_allclose(
            controller.batch_controls[-1, :, 0], 0.01 + times, rtol=0, atol=1e-12
        )


def test_on_a_task_that_plans_low_level_commands_a_chunk_policy_proposes_commands():
    with pytest.raises(
        judo.PolicyError,
        match=r"^policy 'constant' is an action policy, but CartpolePD plans a low-level policy's "
        r"commands, where "
        r"only a chunk policy \(horizon > 1\) can propose; its closed loop would bypass the "
        r"low-level policy$",
    ):
        judo.make_controller(
            "cartpole_pd", "ps", proposal_policy=ConstantPolicy(0.0, 1, observation_size=5)
        )
    config = judo.ControllerConfig(horizon=0.3, policy_samples=1)
    # far beyond the command range: clamped to it, like the optimizer's knots
    policy = ConstantPolicy(99.0, 3, observation_size=5)
    with judo.make_controller(
        "cartpole_pd", "ps", controller_config=config, proposal_policy=policy, num_workers=1
    ) as c:
        c.update_action(np.array([0.0, 3.1, 0.0, 0.0]), 0.0)
        expected = np.full((c.num_steps, 1), c.task.command_range[0, 1])
        # a cubic rounds
        np.testing.assert_allclose(c.batch_controls[-1], expected, rtol=0, atol=1e-12)
