"""The controller loop: improvement over iterations, clamping, NaN handling, warm start and live
resizing."""

import numpy as np
import pytest

import judo
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


def make(task, optimizer_config=None, **controller_fields):
    optimizer = PredictiveSampling(
        optimizer_config or PredictiveSamplingConfig(num_rollouts=16, sigma=0.5), task.nu
    )
    optimizer.rng = np.random.default_rng(0)
    return judo.Controller(
        judo.ControllerConfig(**controller_fields), task, optimizer, num_workers=2
    )


def test_cartpole_reward_improves_over_iterations():
    controller = judo.make_controller(
        "cartpole",
        "ps",
        controller_config=judo.ControllerConfig(
            horizon=1.0, spline_order="cubic", control_freq=50.0
        ),
        optimizer_config=PredictiveSamplingConfig(num_rollouts=32, sigma=0.3),
        seed=0,
        num_workers=2,
    )  # fixed settings, so that re-tuned defaults do not change what this tests
    state = np.array([0.0, np.pi, 0.0, 0.0])  # hanging down
    best = []
    for _ in range(15):
        controller.update_action(state, 0.0)
        best.append(controller.rewards.max())
    controller.close()
    assert best[-1] > best[0] + 1.0  # same start state: later plans roll out strictly better
    # ps never loses its best
    assert all(b2 >= b1 - 1e-9 for b1, b2 in zip(best, best[1:], strict=False))


def test_samples_are_clamped_to_the_actuator_range(upright_task):
    controller = make(upright_task, PredictiveSamplingConfig(num_rollouts=16, sigma=50.0))
    controller.update_action(np.zeros(4), 0.0)
    assert np.abs(controller.nominal_knots).max() <= 1.0
    assert np.abs(controller.action(0.3)).max() <= 1.0


def test_nan_rewards_never_win(upright_task):
    poisoned = []

    def reward(states, sensors, controls, config, system_metadata=None):
        values = -np.abs(controls).sum((1, 2))
        values[1:] = np.nan  # everything but the nominal is NaN
        poisoned.append(True)
        return values

    upright_task.reward = reward
    controller = make(upright_task)
    controller.update_action(np.zeros(4), 0.0)
    assert (
        poisoned and controller.rewards[0] > -np.inf and np.all(controller.rewards[1:] == -np.inf)
    )
    np.testing.assert_array_equal(controller.nominal_knots, np.zeros((4, 1)))  # the nominal won


@pytest.mark.parametrize("optimizer", ["ps", "mppi"])
def test_inf_rewards_never_win_and_keep_mppi_weights_finite(upright_task, optimizer):
    def reward(states, sensors, controls, config, system_metadata=None):
        values = -np.abs(controls).sum((1, 2))
        values[1:] = np.inf  # everything but the nominal "scores" +inf, as a diverged reward may
        return values

    upright_task.reward = reward
    config = MPPIConfig(num_rollouts=16, sigma=0.5) if optimizer == "mppi" else None
    controller = (
        make(upright_task)
        if config is None
        else judo.Controller(
            judo.ControllerConfig(), upright_task, MPPI(config, upright_task.nu), num_workers=2
        )
    )
    controller.update_action(np.zeros(4), 0.0)
    assert controller.rewards[0] > -np.inf and np.all(controller.rewards[1:] == -np.inf)
    assert np.isfinite(controller.nominal_knots).all()
    np.testing.assert_array_equal(controller.nominal_knots, np.zeros((4, 1)))  # the nominal won


def test_all_nan_rewards_raise_and_keep_the_previous_plan(upright_task):
    controller = make(upright_task)
    controller.update_action(np.zeros(4), 0.0)
    plan_before = controller.nominal_knots.copy()
    upright_task.reward = lambda *args, **kwargs: np.full(16, np.nan)
    with pytest.raises(
        judo.NonFiniteRewardError, match="all 16 rollouts of UprightTask scored NaN or -inf"
    ):
        controller.update_action(np.zeros(4), 0.02)
    np.testing.assert_array_equal(controller.nominal_knots, plan_before)


def test_reward_of_the_wrong_shape_is_named(upright_task):
    upright_task.reward = lambda *args, **kwargs: np.zeros(3)
    with pytest.raises(judo.JudoError, match=r"reward returned shape \(3,\), expected \(16,\)"):
        make(upright_task).update_action(np.zeros(4), 0.0)


def test_warm_start_shifts_the_previous_plan(upright_task):
    controller = make(upright_task, spline_order="linear", horizon=0.3)
    controller.update_action(np.zeros(4), 0.0)
    plan = controller.nominal_knots.copy()
    seen = []
    controller.optimizer.sample_control_knots = lambda nominal: (
        seen.append(nominal.copy()) or np.repeat(nominal[None], 16, 0)
    )
    controller.update_action(np.zeros(4), 0.1)
    expected = judo.Spline(0.0, judo.SplineBasis(np.linspace(0, 0.3, 4), "linear"), plan)(
        0.1 + np.linspace(0, 0.3, 4)
    )
    np.testing.assert_allclose(seen[0], expected)


def test_reward_sees_a_config_snapshot_and_metadata_reaches_it(upright_task):
    seen = []

    def reward(states, sensors, controls, config, system_metadata=None):
        seen.append((config, system_metadata))
        return np.zeros(len(states))

    upright_task.reward = reward
    make(upright_task).update_action(np.zeros(4), 0.0, {"goal": 1})
    config, metadata = seen[0]
    assert (
        config is not upright_task.config
        and config == upright_task.config
        and metadata == {"goal": 1}
    )


def test_live_resize_of_rollouts_knots_and_horizon(upright_task):
    controller = make(upright_task)
    controller.update_action(np.zeros(4), 0.0)
    controller.optimizer.config.num_rollouts = 9
    controller.optimizer.config.num_nodes = 6
    controller.config.horizon = 0.5
    controller.update_action(np.zeros(4), 0.02)
    assert controller.rewards.shape == (9,) and controller.nominal_knots.shape == (6, 1)
    # nominal + 5 best, T = 0.5 s / 0.01 s, one trace sensor
    assert controller.traces.shape == (6, 50, 1, 3)


def test_traces_follow_the_trace_sensors_of_the_best_rollouts(upright_task):
    controller = make(upright_task, max_num_traces=3)
    controller.update_action(np.array([0.0, 0.2, 0.0, 0.0]), 0.0)
    traces = controller.traces
    assert traces.shape == (4, 100, 1, 3)
    assert np.isfinite(traces).all()
    np.testing.assert_allclose(traces[..., 1], 0.0)  # a planar model: the tip never leaves y = 0
    tip_height = traces[..., 2]
    # the tip moves on a 0.6 m circle around the cart
    assert np.all(np.abs(tip_height) <= 0.6 + 1e-9)


def test_mppi_balances_the_tiny_cartpole_near_upright(upright_task):
    optimizer = MPPI(MPPIConfig(num_rollouts=32, sigma=0.3, temperature=0.05), upright_task.nu)
    optimizer.rng = np.random.default_rng(1)
    controller = judo.Controller(
        judo.ControllerConfig(horizon=1.0), upright_task, optimizer, num_workers=2
    )
    from judo.loop.system import MujocoSystem

    upright_task.data.qpos[:] = [0.0, 0.15]
    system = MujocoSystem(upright_task)
    for step in range(300):
        reading = system.read_state()
        if step % 5 == 0:
            controller.update_action(reading.state, reading.time)
        system.apply(controller.action(reading.time))
        system.step()
    assert (
        abs(np.cos(upright_task.data.qpos[1])) > 0.95 and np.cos(upright_task.data.qpos[1]) > 0
    )  # still upright after 3 s
