"""er_cma: MPPI-CMA with an entropy bonus growing along the horizon, and closed-loop swing-ups."""

import numpy as np
import pytest
from closed_loop import plan_with_everything, swing_up_metric

import judo
from judo.optimizers.er_cma import ERCMA, ERCMAConfig
from judo.optimizers.mppi_cma import MPPICMA, MPPICMAConfig


def test_the_bonus_inflates_the_learned_covariance_more_at_the_far_knots():
    fields = dict(num_rollouts=64, num_nodes=4, sigma_min=1e-3, sigma_max=10.0, adaptation_rate=1.0)
    er = ERCMA(ERCMAConfig(entropy_bonus_start=0.0, entropy_bonus_end=0.6, **fields), 2)
    plain = MPPICMA(MPPICMAConfig(**fields), 2)
    er.rng, plain.rng = np.random.default_rng(0), np.random.default_rng(0)
    np.testing.assert_allclose(er.covariance_gain(), 1 / (1 - np.array([0.0, 0.2, 0.4, 0.6])))
    nominal = np.zeros((4, 2))
    knots = er.sample_control_knots(nominal)
    np.testing.assert_array_equal(knots, plain.sample_control_knots(nominal))
    rewards = -np.abs(knots - 0.3).sum(axis=(1, 2))
    np.testing.assert_array_equal(
        er.update_nominal_knots(knots, rewards), plain.update_nominal_knots(knots, rewards)
    )
    np.testing.assert_allclose(
        er.covariance, plain.covariance * er.covariance_gain()[:, None, None], rtol=1e-10
    )


def test_no_bonus_is_mppi_cma_bit_for_bit():
    er = ERCMA(ERCMAConfig(entropy_bonus_start=0.0, entropy_bonus_end=0.0), 3)
    plain = MPPICMA(MPPICMAConfig(), 3)
    er.rng, plain.rng = np.random.default_rng(5), np.random.default_rng(5)
    knots = er.sample_control_knots(np.ones((4, 3)))
    plain.sample_control_knots(np.ones((4, 3)))
    rewards = -np.square(knots).sum(axis=(1, 2))
    er.update_nominal_knots(knots, rewards)
    plain.update_nominal_knots(knots, rewards)
    assert er.covariance.tobytes() == plain.covariance.tobytes()


def test_the_eigenvalues_stay_within_the_bounds_under_a_large_bonus():
    er = ERCMA(
        ERCMAConfig(
            num_rollouts=32,
            entropy_bonus_end=0.95,
            sigma_min=0.1,
            sigma_max=0.4,
            adaptation_rate=1.0,
        ),
        2,
    )
    nominal = np.zeros((4, 2))
    for _ in range(5):
        knots = er.sample_control_knots(nominal)
        knots[3] = 9.0  # a far sample with a good reward, as a proposal may be
        rewards = np.zeros(32)
        rewards[4:] = -np.inf
        nominal = er.update_nominal_knots(knots, rewards)
        eigenvalues = np.linalg.eigvalsh(er.covariance)
        assert eigenvalues.min() >= 0.01 - 1e-12 and eigenvalues.max() <= 0.16 + 1e-12
    assert np.isfinite(nominal).all()


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(
        judo.ConfigError,
        match=r"^entropy_bonus_end must be "
        r"between 0 and 0.95, got 1.0$",
    ):
        ERCMAConfig(entropy_bonus_end=1.0)
    with pytest.raises(
        judo.ConfigError,
        match=r"^entropy_bonus_start must be "
        r"between 0 and 0.95, got -0.1$",
    ):
        ERCMAConfig(entropy_bonus_start=-0.1)
    with pytest.raises(judo.ConfigError, match=r"^need 0 < sigma_min <= sigma_max, got 0.5, 0.2$"):
        ERCMAConfig(sigma_min=0.5, sigma_max=0.2)


def test_it_is_registered_for_the_cli_and_the_gui():
    assert judo.get_registered_optimizers()["er_cma"] == (ERCMA, ERCMAConfig)


@pytest.mark.slow
def test_it_plans_through_robust_planning_proposals_and_a_low_level_policy():
    controller = plan_with_everything("er_cma")
    assert np.isfinite(controller.rewards).all() and controller.rewards.shape == (16,)
    assert np.abs(controller.nominal_knots).max() <= controller.task.command_range[0, 1]


@pytest.mark.slow
@pytest.mark.parametrize("task_name", ["pendulum", "cartpole"])
def test_it_swings_up_in_closed_loop(task_name):
    assert swing_up_metric(task_name, "er_cma") > 0.9
