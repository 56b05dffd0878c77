"""iCEM: colored noise, the elite memory, the CEM refit, and shifting state between cycles."""

import numpy as np
import pytest

import judo
from judo.optimizers.icem import ICEM, ICEMConfig, colored_noise
from judo.optimizers.knot_shift import shift_knots


def make_icem(nu: int = 2, seed: int = 0, **fields) -> ICEM:
    optimizer = ICEM(ICEMConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def spectral_slope(noise: np.ndarray) -> float:
    """Least-squares slope of log power against log frequency, averaged over the rows of `noise`."""
    n = noise.shape[-1]
    power = np.square(np.abs(np.fft.rfft(noise, axis=-1))).mean(axis=0)[1 : n // 2]
    freqs = np.fft.rfftfreq(n)[1 : n // 2]
    return float(np.polyfit(np.log(freqs), np.log(power), 1)[0])


@pytest.mark.parametrize("beta", [0.0, 1.0, 2.0, 3.0])
def test_colored_noise_has_the_requested_spectral_slope_and_unit_variance(beta):
    noise = colored_noise(np.random.default_rng(0), beta, (2000, 128))
    assert spectral_slope(noise) == pytest.approx(-beta, abs=0.1)
    assert noise.var() == pytest.approx(1.0, rel=0.05)
    # stationary: every position alike
    np.testing.assert_allclose(noise.var(axis=0), 1.0, rtol=0.15)


def test_colored_noise_handles_short_sequences_and_empty_batches():
    for n in (1, 2, 3, 4):
        assert colored_noise(np.random.default_rng(0), 2.0, (5, 3, n)).shape == (5, 3, n)
    assert colored_noise(np.random.default_rng(0), 2.0, (0, 3, 4)).shape == (0, 3, 4)


def test_higher_beta_makes_neighbouring_knots_more_alike():
    def neighbour_correlation(beta: float) -> float:
        noise = colored_noise(np.random.default_rng(1), beta, (20000, 8))
        return float(np.corrcoef(noise[:, 2], noise[:, 3])[0, 1])

    assert neighbour_correlation(0.0) == pytest.approx(0.0, abs=0.03)
    assert neighbour_correlation(0.0) < neighbour_correlation(1.0) < neighbour_correlation(2.5)


def test_samples_are_plan_mean_kept_elites_then_fresh():
    icem = make_icem(num_rollouts=10, num_nodes=3, num_elites=5, elite_keep_fraction=0.6)
    nominal = np.zeros((3, 2))
    knots = icem.sample_control_knots(nominal)
    np.testing.assert_array_equal(knots[0], nominal)
    np.testing.assert_array_equal(knots[1], nominal)  # the mean starts at the first nominal
    rewards = -np.square(knots - 0.4).sum(axis=(1, 2))
    plan = icem.update_nominal_knots(knots, rewards)
    ranked = np.argsort(-rewards)
    np.testing.assert_array_equal(plan, knots[ranked[0]])
    np.testing.assert_allclose(icem.mean, knots[ranked[:5]].mean(axis=0))
    np.testing.assert_allclose(icem.sigma, np.clip(knots[ranked[:5]].std(axis=0), 0.15, 0.5))
    # 3 kept, the best is the plan
    np.testing.assert_array_equal(icem.kept_elites, knots[ranked[1:3]])

    again = icem.sample_control_knots(plan)
    np.testing.assert_array_equal(again[0], plan)
    np.testing.assert_array_equal(again[1], icem.mean)
    np.testing.assert_array_equal(again[2:4], knots[ranked[1:3]])  # kept elites are sampled again
    assert again.shape == (10, 3, 2)


def test_sigma_is_clipped_like_cem():
    icem = make_icem(num_rollouts=8, num_elites=4, sigma_min=0.2, sigma_max=0.3)
    knots = np.zeros((8, icem.num_nodes, 2))
    knots[:4, 0, 0] = [-5.0, 5.0, -5.0, 5.0]  # wide spread on one entry, none elsewhere
    icem.update_nominal_knots(knots, np.arange(8.0)[::-1])
    assert icem.sigma[0, 0] == 0.3 and (icem.sigma.ravel()[1:] == 0.2).all()


def test_elites_mean_and_sigma_shift_to_new_knot_times():
    icem = make_icem(num_rollouts=16, num_nodes=4, num_elites=6, elite_keep_fraction=0.5)
    knots = icem.sample_control_knots(np.zeros((4, 2)))
    icem.update_nominal_knots(knots, -np.abs(knots - 0.3).sum(axis=(1, 2)))
    kept, mean, sigma = icem.kept_elites.copy(), icem.mean.copy(), icem.sigma.copy()
    old_times, new_times = np.linspace(0.0, 1.0, 4), np.linspace(0.05, 1.05, 6)
    icem.num_nodes = 6  # as the controller sets it before pre_optimization
    icem.pre_optimization(old_times, new_times)
    np.testing.assert_allclose(icem.kept_elites, shift_knots(kept, old_times, new_times))
    np.testing.assert_allclose(icem.mean, shift_knots(mean, old_times, new_times))
    np.testing.assert_allclose(icem.sigma, shift_knots(sigma, old_times, new_times))
    assert icem.sample_control_knots(np.zeros((6, 2))).shape == (16, 6, 2)


def test_few_rollouts_truncate_the_fixed_samples():
    icem = make_icem(num_rollouts=3, num_nodes=2, num_elites=3, elite_keep_fraction=1.0)
    knots = icem.sample_control_knots(np.zeros((2, 2)))
    icem.update_nominal_knots(knots, np.array([0.0, 1.0, 2.0]))
    assert icem.sample_control_knots(knots[2]).shape == (3, 2, 2)


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(
        judo.ConfigError,
        match=r"^elite_keep_fraction must "
        r"be between 0 and 1, got 1.5$",
    ):
        ICEMConfig(elite_keep_fraction=1.5)
    with pytest.raises(judo.ConfigError, match=r"^beta must be between 0 and 10, got -1.0$"):
        ICEMConfig(beta=-1.0)
    with pytest.raises(
        judo.ConfigError,
        match=r"^num_elites must be between 1 "
        r"and num_rollouts \(8\), got 9$",
    ):
        ICEMConfig(num_rollouts=8, num_elites=9)


def test_same_seed_same_samples():
    nominal = np.zeros((4, 2))
    np.testing.assert_array_equal(
        make_icem(seed=2).sample_control_knots(nominal),
        make_icem(seed=2).sample_control_knots(nominal),
    )
    assert not np.array_equal(
        make_icem(seed=2).sample_control_knots(nominal),
        make_icem(seed=3).sample_control_knots(nominal),
    )
