"""CMA-ES (diagonal): Hansen's parameters, the update rule on hand-made rewards, and carried
state."""

import numpy as np
import pytest

import judo
from judo.optimizers.cmaes import CMAES, CMAESConfig, cmaes_parameters


def make_cmaes(nu: int = 2, seed: int = 0, **fields) -> CMAES:
    optimizer = CMAES(CMAESConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def optimize(cmaes: CMAES, reward, nominal: np.ndarray, generations: int) -> np.ndarray:
    """Run `generations` iterations maximising `reward` (num_rollouts, num_nodes, nu) ->
    (num_rollouts,)."""
    for _ in range(generations):
        knots = cmaes.sample_control_knots(nominal)
        nominal = cmaes.update_nominal_knots(knots, reward(knots))
    return nominal


def test_parameters_follow_hansens_defaults():
    lam, n = 15, 8
    p = cmaes_parameters(lam, n)
    assert p.mu == 7
    raw = np.log(8.0) - np.log(np.arange(1, 8))
    np.testing.assert_allclose(p.weights, raw / raw.sum())
    assert p.mu_eff == pytest.approx(1 / np.sum(p.weights**2))
    assert p.c_sigma == pytest.approx((p.mu_eff + 2) / (n + p.mu_eff + 5))
    full_c1 = 2 / ((n + 1.3) ** 2 + p.mu_eff)
    assert p.c_1 == pytest.approx(full_c1 * (n + 2) / 3)  # sep-CMA-ES speed-up
    assert 0 < p.c_1 + p.c_mu <= 1
    assert p.chi_n == pytest.approx(np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n**2)))


def test_mean_moves_toward_the_best_samples():
    cmaes = make_cmaes(num_rollouts=32, num_nodes=3, sigma=0.3, execute_best=False)
    target = np.full((3, 2), 0.5)
    nominal = np.zeros((3, 2))
    knots = cmaes.sample_control_knots(nominal)
    new_mean = cmaes.update_nominal_knots(knots, -np.square(knots - target).sum(axis=(1, 2)))
    assert np.linalg.norm(new_mean - target) < np.linalg.norm(nominal - target) - 0.1


def test_plan_is_the_best_sample_when_execute_best():
    cmaes = make_cmaes(num_rollouts=8)
    knots = cmaes.sample_control_knots(np.zeros((cmaes.num_nodes, 2)))
    rewards = np.random.default_rng(1).normal(size=8)
    np.testing.assert_array_equal(
        cmaes.update_nominal_knots(knots, rewards), knots[np.argmax(rewards)]
    )


def test_converges_on_a_quadratic_with_a_positive_covariance():
    cmaes = make_cmaes(
        num_rollouts=16, num_nodes=5, sigma=0.5, sigma_min=1e-9, sigma_max=10.0, execute_best=False
    )
    target = np.linspace(-1.0, 1.0, 10).reshape(5, 2)
    final = optimize(
        cmaes, lambda k: -np.square(k - target).sum(axis=(1, 2)), np.zeros((5, 2)), 150
    )
    np.testing.assert_allclose(final, target, atol=1e-3)
    assert np.isfinite(cmaes.variances).all() and (cmaes.variances > 0).all()
    # C keeps mean 1; its scale lives in step_size
    assert cmaes.variances.mean() == pytest.approx(1.0)


def test_diagonal_adapts_to_the_scaling_of_each_coordinate():
    cmaes = make_cmaes(
        num_rollouts=16, num_nodes=2, sigma=0.5, sigma_min=1e-9, sigma_max=10.0, execute_best=False
    )
    curvature = np.array([[1.0, 100.0], [1.0, 100.0]])  # the second control is 10x more sensitive
    optimize(
        cmaes, lambda k: -(curvature * np.square(k - 0.3)).sum(axis=(1, 2)), np.zeros((2, 2)), 50
    )
    stds = np.sqrt(cmaes.variances.reshape(2, 2))
    assert (stds[:, 0] / stds[:, 1] > 6).all()  # ideally 10: C ~ inverse Hessian


def test_spread_stays_within_bounds():
    cmaes = make_cmaes(num_rollouts=16, sigma=0.3, sigma_min=0.1, sigma_max=0.4)
    rng = np.random.default_rng(2)
    optimize(cmaes, lambda k: rng.normal(size=len(k)), np.zeros((cmaes.num_nodes, 2)), 50)
    stds = cmaes.step_size * np.sqrt(cmaes.variances)
    assert (stds >= 0.1 - 1e-12).all() and (stds <= 0.4 + 1e-12).all()


def test_failed_population_keeps_plan_and_distribution():
    cmaes = make_cmaes(num_rollouts=4)
    nominal = np.ones((cmaes.num_nodes, 2))
    knots = cmaes.sample_control_knots(nominal)
    before = cmaes.variances.copy()
    plan = cmaes.update_nominal_knots(knots, np.array([1.0, -np.inf, -np.inf, -np.inf]))
    np.testing.assert_array_equal(plan, nominal)
    np.testing.assert_array_equal(cmaes.variances, before)


def test_state_is_reinterpolated_when_knots_shift_or_change_count():
    cmaes = make_cmaes(num_nodes=4)
    cmaes.variances = np.repeat([0.5, 1.0, 1.5, 2.0], 2)  # per knot, mean 1.25
    cmaes.path_c = np.repeat([1.0, 2.0, 3.0, 4.0], 2)
    cmaes.num_nodes = 7  # the controller sets the new size before pre_optimization
    cmaes.pre_optimization(np.linspace(0.0, 1.0, 4), np.linspace(0.0, 1.0, 7))
    assert cmaes.variances.shape == cmaes.path_c.shape == cmaes.path_sigma.shape == (14,)
    per_knot = cmaes.variances.reshape(7, 2)[:, 0]
    assert (np.diff(per_knot) > 0).all() and cmaes.variances.mean() == pytest.approx(1.0)
    np.testing.assert_allclose(
        cmaes.path_c.reshape(7, 2)[[0, 3, 6], 0] * np.sqrt(1.25), [1.0, 2.5, 4.0]
    )


def test_editing_sigma_restarts_the_distribution():
    cmaes = make_cmaes(num_nodes=4)
    optimize(cmaes, lambda k: -np.square(k - 0.5).sum(axis=(1, 2)), np.zeros((4, 2)), 5)
    assert cmaes.generation == 5
    cmaes.config = judo.core.configuration.config.with_updates(cmaes.config, {"sigma": 0.2})
    times = np.linspace(0.0, 1.0, 4)
    cmaes.pre_optimization(times, times)
    assert cmaes.generation == 0 and cmaes.step_size == pytest.approx(0.2)


def test_needs_a_population():
    with pytest.raises(
        judo.ConfigError,
        match=r"^CMA-ES needs num_rollouts >= 2 "
        r"\(the plan plus a population\), got 1$",
    ):
        CMAESConfig(num_rollouts=1)
    with pytest.raises(judo.ConfigError, match=r"^need 0 < sigma_min <= sigma_max, got 0.5, 0.2$"):
        CMAESConfig(sigma_min=0.5, sigma_max=0.2)


def test_same_seed_same_run():
    def run(seed: int) -> np.ndarray:
        cmaes = make_cmaes(seed=seed, num_rollouts=8)
        return optimize(
            cmaes, lambda k: -np.abs(k - 0.2).sum(axis=(1, 2)), np.zeros((cmaes.num_nodes, 2)), 4
        )

    np.testing.assert_array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))
