"""ps, cem and mppi update rules on hand-made rewards, and their sampling conventions."""

import numpy as np
import pytest

from judo.core.optimizer import weighted_knots
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


def hand_made_samples(num_rollouts=6, num_nodes=3, nu=2):
    return np.arange(num_rollouts * num_nodes * nu, dtype=float).reshape(
        num_rollouts, num_nodes, nu
    )


def test_predictive_sampling_keeps_the_nominal_first_and_picks_the_best():
    opt = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=6, num_nodes=3, sigma=0.1), nu=2)
    nominal = np.ones((3, 2))
    samples = opt.sample_control_knots(nominal)
    assert samples.shape == (6, 3, 2)
    np.testing.assert_array_equal(samples[0], nominal)
    assert 0.03 < np.std(samples[1:] - nominal) < 0.3
    knots = hand_made_samples()
    np.testing.assert_array_equal(
        opt.update_nominal_knots(knots, np.array([0, 1, 5, 2, -np.inf, 3.0])), knots[2]
    )


def test_mppi_with_tiny_temperature_picks_the_argmax():
    opt = MPPI(MPPIConfig(num_rollouts=6, num_nodes=3, temperature=1e-6), nu=2)
    knots = hand_made_samples()
    np.testing.assert_allclose(
        opt.update_nominal_knots(knots, np.array([0, 1, 5, 2, 4.9, 3.0])), knots[2]
    )


def test_mppi_with_huge_temperature_averages_and_ignores_minus_inf():
    opt = MPPI(MPPIConfig(num_rollouts=6, num_nodes=3, temperature=1e9), nu=2)
    knots = hand_made_samples()
    rewards = np.array([0, 1, 5, 2, -np.inf, 3.0])
    np.testing.assert_allclose(
        opt.update_nominal_knots(knots, rewards), knots[[0, 1, 2, 3, 5]].mean(0), rtol=1e-6
    )


def test_mppi_weights_follow_the_softmax_formula():
    opt = MPPI(MPPIConfig(num_rollouts=3, num_nodes=1, temperature=2.0), nu=1)
    knots = np.array([[[0.0]], [[1.0]], [[2.0]]])
    rewards = np.array([0.0, 2.0, 4.0])
    weights = np.exp(rewards / 2.0) / np.exp(rewards / 2.0).sum()
    assert opt.update_nominal_knots(knots, rewards)[0, 0] == pytest.approx(
        weights @ [0.0, 1.0, 2.0]
    )


def test_cem_fits_mean_and_clipped_std_of_its_elites():
    opt = CEM(
        CEMConfig(num_rollouts=6, num_nodes=3, num_elites=2, sigma_min=0.01, sigma_max=100.0), nu=2
    )
    knots = hand_made_samples()
    rewards = np.array([0, 1, 5, 2, 4, 3.0])  # elites: samples 2 and 4
    np.testing.assert_allclose(opt.update_nominal_knots(knots, rewards), knots[[2, 4]].mean(0))
    np.testing.assert_allclose(opt.sigma, knots[[2, 4]].std(0))
    opt.config.sigma_max = 1.0
    opt.update_nominal_knots(knots, rewards)
    np.testing.assert_allclose(opt.sigma, 1.0)  # std 6 clipped to sigma_max


def test_cem_resets_its_std_when_num_nodes_changes():
    opt = CEM(CEMConfig(num_rollouts=6, num_nodes=3, sigma_max=0.7), nu=2)
    opt.sigma[:] = 0.1
    opt.num_nodes = 5
    opt.pre_optimization(np.zeros(3), np.zeros(5))
    assert opt.sigma.shape == (5, 2) and np.all(opt.sigma == 0.7)


def test_noise_ramp_grows_linearly_to_noise_ramp_at_the_last_knot():
    opt = PredictiveSampling(
        PredictiveSamplingConfig(num_nodes=4, use_noise_ramp=True, noise_ramp=2.0), nu=1
    )
    np.testing.assert_allclose(opt.noise_ramp_scale()[:, 0], [0.5, 1.0, 1.5, 2.0])


def test_sampling_is_deterministic_for_a_seed():
    def draw(seed):
        opt = MPPI(MPPIConfig(num_rollouts=8, num_nodes=4), nu=3)
        opt.rng = np.random.default_rng(seed)
        return opt.sample_control_knots(np.zeros((4, 3)))

    np.testing.assert_array_equal(draw(3), draw(3))
    assert not np.array_equal(draw(3), draw(4))


def test_cem_keeps_its_std_free_of_the_noise_ramp():
    """With the ramp on, the samples' std is sigma times the ramp; refitting the elites divides it
    out again, so the ramp is applied once per draw instead of compounding across cycles."""
    config = CEMConfig(
        num_rollouts=4000, num_nodes=4, num_elites=4000, sigma_min=0.01, sigma_max=1.0
    )
    config.use_noise_ramp, config.noise_ramp = True, 2.0
    opt = CEM(config, nu=1)
    opt.sigma[:] = 0.2
    samples = opt.sample_control_knots(np.zeros((4, 1)))
    np.testing.assert_allclose(
        samples[1:].std(0)[:, 0], 0.2 * np.array([0.5, 1.0, 1.5, 2.0]), rtol=0.06
    )
    opt.update_nominal_knots(samples, np.zeros(4000))
    np.testing.assert_allclose(opt.sigma, 0.2, rtol=0.06)


@pytest.mark.parametrize("use_noise_ramp", [False, True])
@pytest.mark.parametrize("sigma", [0.3, np.array([[0.1], [0.2], [0.4]]), np.full((3, 2), 0.7)])
def test_perturb_draws_the_same_numbers_as_a_fresh_noise_array(use_noise_ramp, sigma):
    config = MPPIConfig(num_rollouts=7, num_nodes=3, use_noise_ramp=use_noise_ramp, noise_ramp=3.0)
    fast, reference = MPPI(config, nu=2), MPPI(config, nu=2)
    fast.rng, reference.rng = np.random.default_rng(4), np.random.default_rng(4)
    nominal = np.random.default_rng(1).normal(size=(3, 2))
    noise = reference.rng.standard_normal((6, 3, 2))  # the plain formula, bit for bit
    noise *= sigma * reference.noise_ramp_scale()
    noise += nominal
    expected = np.concatenate([nominal[None], noise])
    assert fast.perturb(nominal, sigma).tobytes() == expected.tobytes()
    # the generators stay in step
    assert fast.rng.standard_normal() == reference.rng.standard_normal()


def test_weighted_knots_is_tensordot_bit_for_bit():
    rng = np.random.default_rng(2)
    for num_rollouts, num_nodes, nu in [(1, 2, 1), (32, 4, 1), (33, 5, 3), (256, 8, 12)]:
        weights, knots = rng.random(num_rollouts), rng.normal(size=(num_rollouts, num_nodes, nu))
        expected = np.tensordot(weights, knots, axes=1)
        assert weighted_knots(weights, knots).tobytes() == expected.tobytes()
        strided = np.repeat(knots, 2, axis=0)[::2]  # not contiguous: copied as tensordot copies it
        assert (
            weighted_knots(weights, strided).tobytes()
            == np.tensordot(weights, strided, axes=1).tobytes()
        )
