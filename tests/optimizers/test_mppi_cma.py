"""mppi_cma: MPPI's mean, the weighted covariance with its moving average and eigenvalue clamp,
carried state, and closed-loop swing-ups."""

import numpy as np
import pytest
from closed_loop import plan_with_everything, swing_up_metric

import judo
from judo.optimizers.knot_shift import knot_shift_matrix
from judo.optimizers.mppi import MPPI, MPPIConfig, softmax_weights
from judo.optimizers.mppi_cma import MPPICMA, MPPICMAConfig


def make(nu: int = 2, seed: int = 0, **fields) -> MPPICMA:
    optimizer = MPPICMA(MPPICMAConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def test_the_mean_is_mppi_s_and_the_covariance_the_weighted_one_smoothed():
    opt = make(
        num_rollouts=64,
        num_nodes=3,
        sigma=0.3,
        sigma_min=1e-3,
        sigma_max=10.0,
        adaptation_rate=0.25,
    )
    nominal = np.full((3, 2), 0.1)
    knots = opt.sample_control_knots(nominal)
    np.testing.assert_array_equal(knots[0], nominal)
    rewards = -np.square(knots - 0.4).sum(axis=(1, 2))
    plan = opt.update_nominal_knots(knots, rewards)
    mppi = MPPI(MPPIConfig(num_rollouts=64, num_nodes=3, temperature=0.1), 2)
    np.testing.assert_allclose(plan, mppi.update_nominal_knots(knots, rewards))
    w = softmax_weights(rewards, 0.1)
    for k in range(3):  # the plain formula, knot by knot
        d = knots[:, k] - nominal[k]
        expected = 0.75 * 0.09 * np.eye(2) + 0.25 * (w[:, None] * d).T @ d
        np.testing.assert_allclose(opt.covariance[k], expected, atol=1e-12)
        np.testing.assert_allclose(opt.root[k] @ opt.root[k].T, opt.covariance[k], atol=1e-12)


def test_samples_have_the_adapted_covariance():
    opt = make(num_rollouts=20001, num_nodes=2, sigma_min=0.05, sigma_max=2.0)
    target = np.array([[0.5, 0.2], [0.2, 0.3]])
    opt._set_covariance(np.stack([target, 0.1 * np.eye(2)]))
    knots = opt.sample_control_knots(np.zeros((2, 2)))
    np.testing.assert_allclose(np.cov(knots[1:, 0].T), target, atol=0.02)
    np.testing.assert_allclose(np.cov(knots[1:, 1].T), 0.1 * np.eye(2), atol=0.01)


def test_eigenvalues_are_clamped_and_the_diagonal_mode_drops_correlations():
    opt = make(num_nodes=1, sigma_min=0.1, sigma_max=0.5)
    opt._set_covariance(np.array([[[1.0, 0.999], [0.999, 1.0]]]))  # eigenvalues 1.999 and 0.001
    np.testing.assert_allclose(np.linalg.eigvalsh(opt.covariance[0]), [0.01, 0.25])
    diagonal = make(num_nodes=1, sigma_min=0.1, sigma_max=0.5, full_covariance=False)
    diagonal._set_covariance(np.array([[[1.0, 0.999], [0.999, 0.001]]]))
    np.testing.assert_allclose(diagonal.covariance[0], np.diag([0.25, 0.01]))


def test_minus_inf_rewards_get_no_weight():
    opt = make(num_rollouts=6, num_nodes=2, temperature=1e9)
    knots = opt.sample_control_knots(np.zeros((2, 2)))
    knots[4] = 50.0
    plan = opt.update_nominal_knots(knots, np.array([0.0, 1.0, 2.0, 3.0, -np.inf, 4.0]))
    np.testing.assert_allclose(plan, knots[[0, 1, 2, 3, 5]].mean(axis=0), rtol=1e-6)
    assert (
        np.isfinite(opt.covariance).all()
        and np.linalg.eigvalsh(opt.covariance).max() <= 1.0 + 1e-12
    )


def test_the_covariance_shifts_with_the_knots_and_restarts_on_a_new_sigma():
    opt = make(num_nodes=3, sigma_min=0.01, sigma_max=5.0)
    opt._set_covariance(np.stack([np.eye(2) * v for v in (0.1, 0.2, 0.4)]))
    old_times, new_times = np.linspace(0.0, 1.0, 3), np.linspace(0.1, 1.1, 5)
    expected = np.einsum("nk,kij->nij", knot_shift_matrix(old_times, new_times), opt.covariance)
    opt.num_nodes = 5
    opt.pre_optimization(old_times, new_times)
    np.testing.assert_allclose(opt.covariance, expected)
    assert opt.sample_control_knots(np.zeros((5, 2))).shape == (32, 5, 2)
    opt.config.sigma = 0.2
    opt.pre_optimization(new_times, new_times)
    np.testing.assert_allclose(opt.covariance, np.tile(0.04 * np.eye(2), (5, 1, 1)))


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(judo.ConfigError, match=r"^need 0 < sigma_min <= sigma_max, got 0.5, 0.2$"):
        MPPICMAConfig(sigma_min=0.5, sigma_max=0.2)
    with pytest.raises(
        judo.ConfigError,
        match=r"^adaptation_rate must be "
        r"between 0 and 1, got 1.5$",
    ):
        MPPICMAConfig(adaptation_rate=1.5)
    with pytest.raises(judo.ConfigError, match=r"^temperature must be positive, got 0.0$"):
        MPPICMAConfig(temperature=0.0)


def test_it_is_registered_for_the_cli_and_the_gui():
    assert judo.get_registered_optimizers()["mppi_cma"] == (MPPICMA, MPPICMAConfig)


@pytest.mark.slow
def test_it_plans_through_robust_planning_proposals_and_a_low_level_policy():
    controller = plan_with_everything("mppi_cma")
    assert np.isfinite(controller.rewards).all() and controller.rewards.shape == (16,)
    assert np.abs(controller.nominal_knots).max() <= controller.task.command_range[0, 1]


@pytest.mark.slow
@pytest.mark.parametrize("task_name", ["pendulum", "cartpole"])
def test_it_swings_up_in_closed_loop(task_name):
    assert swing_up_metric(task_name, "mppi_cma") > 0.9
