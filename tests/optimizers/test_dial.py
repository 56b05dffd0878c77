"""DIAL-MPC: the annealed noise schedule, the softmax update, and the iteration count per cycle."""

import numpy as np
import pytest

import judo
from judo.core.configuration.config import with_updates
from judo.optimizers.dial import Dial, DialConfig, standardised_softmax_weights


def make_dial(nu: int = 2, seed: int = 0, **fields) -> Dial:
    optimizer = Dial(DialConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def test_noise_schedule_matches_the_paper_formula():
    cfg = dict(sigma=0.5, beta_opt_iter=0.5, beta_horizon=2.0, anneal_iters=3, num_nodes=4)
    dial = make_dial(**cfg)
    for k in range(3):
        # sigma * exp(-k / (beta_1 N) - (H - 1 - h) / (beta_2 H)), h = 0..H-1
        expected = [0.5 * np.exp(-k / (0.5 * 3) - (3 - h) / (2.0 * 4)) for h in range(4)]
        np.testing.assert_allclose(dial.noise_std(k)[:, 0], expected)
    np.testing.assert_allclose(dial.noise_std(7), dial.noise_std(2))  # past N: the last level


def test_noise_grows_along_the_horizon_and_shrinks_over_iterations():
    dial = make_dial(num_nodes=5, anneal_iters=4)
    levels = np.stack([dial.noise_std(k)[:, 0] for k in range(4)])  # (iteration, knot)
    assert (np.diff(levels, axis=1) > 0).all()
    assert (np.diff(levels, axis=0) < 0).all()
    assert levels[0, -1] == pytest.approx(dial.config.sigma)


def test_samples_have_the_scheduled_std_around_the_nominal():
    dial = make_dial(num_rollouts=20001, num_nodes=4, anneal_iters=2, beta_opt_iter=0.5)
    nominal = np.array([[0.1, -0.2], [0.0, 0.3], [0.5, 0.5], [-0.4, 0.0]])
    for k in range(2):
        dial.iteration = k
        samples = dial.sample_control_knots(nominal)
        np.testing.assert_array_equal(samples[0], nominal)
        std = (samples[1:] - nominal).std(axis=0)  # (num_nodes, nu)
        np.testing.assert_allclose(std, np.broadcast_to(dial.noise_std(k), std.shape), rtol=0.03)


def test_tiny_temperature_picks_the_best_sample():
    dial = make_dial(num_rollouts=16, temperature=1e-6)
    knots = np.random.default_rng(3).normal(size=(16, dial.num_nodes, 2))
    rewards = np.random.default_rng(4).normal(size=16)
    np.testing.assert_allclose(dial.update_nominal_knots(knots, rewards), knots[np.argmax(rewards)])


def test_large_temperature_averages_and_failed_rollouts_get_no_weight():
    weights = standardised_softmax_weights(np.array([1.0, 2.0, -np.inf, 3.0]), temperature=1e6)
    np.testing.assert_allclose(weights, [1 / 3, 1 / 3, 0.0, 1 / 3], atol=1e-5)
    np.testing.assert_allclose(standardised_softmax_weights(np.array([5.0, 5.0]), 0.01), [0.5, 0.5])


def test_weights_do_not_depend_on_the_reward_scale():
    rewards = np.array([-3.0, 1.0, 0.5, 2.0])
    np.testing.assert_allclose(
        standardised_softmax_weights(rewards, 0.5),
        standardised_softmax_weights(100.0 * rewards - 7.0, 0.5),
    )


def test_cycle_ends_after_anneal_iters_and_restarts_the_schedule():
    ctrl = judo.make_controller(
        "cartpole",
        "dial",
        controller_config=judo.ControllerConfig(max_opt_iters=10, spline_order="linear"),
        optimizer_config=DialConfig(anneal_iters=3, num_rollouts=8),
        seed=0,
    )
    seen = []
    original = ctrl.optimizer.sample_control_knots

    def record(nominal):
        seen.append(ctrl.optimizer.iteration)
        return original(nominal)

    ctrl.optimizer.sample_control_knots = record  # type: ignore[method-assign]
    state = np.zeros(4)
    ctrl.update_action(state, 0.0)
    ctrl.update_action(state, 0.05)
    ctrl.close()
    assert seen == [0, 1, 2, 0, 1, 2]


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(judo.ConfigError, match=r"^beta_horizon must be positive, got 0.0$"):
        DialConfig(beta_horizon=0.0)
    with pytest.raises(judo.ConfigError, match=r"^anneal_iters must be between 1 and 100, got 0$"):
        with_updates(DialConfig(), {"anneal_iters": 0})
    with pytest.raises(judo.ConfigError, match=r"^temperature must be positive, got -1.0$"):
        DialConfig(temperature=-1.0)


def test_same_seed_same_samples():
    nominal = np.zeros((4, 2))
    a, b = make_dial(seed=5), make_dial(seed=5)
    np.testing.assert_array_equal(a.sample_control_knots(nominal), b.sample_control_knots(nominal))
    assert not np.array_equal(
        make_dial(seed=6).sample_control_knots(nominal), a.sample_control_knots(nominal)
    )
