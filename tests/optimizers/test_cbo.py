"""cbo: the consensus, the particles' Euler-Maruyama step, the swarm carried across cycles,
closed-loop swing-ups."""

import numpy as np
import pytest
from closed_loop import plan_with_everything, swing_up_metric

import judo
from judo.optimizers.cbo import CBO, CBOConfig
from judo.optimizers.knot_shift import shift_knots
from judo.optimizers.mppi import softmax_weights


def make(nu: int = 2, seed: int = 0, **fields) -> CBO:
    optimizer = CBO(CBOConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def test_the_consensus_is_the_plan_and_particles_step_the_sde():
    opt = make(
        num_rollouts=8,
        num_nodes=3,
        drift=2.0,
        noise=0.5,
        step_size=0.25,
        sigma_min=0.1,
        temperature=0.5,
    )
    nominal = np.zeros((3, 2))
    knots = opt.sample_control_knots(nominal)
    np.testing.assert_array_equal(knots[0], nominal)
    rewards = -np.square(knots - 0.2).sum(axis=(1, 2))
    check = np.random.default_rng(0)
    check.standard_normal((7, 3, 2))  # the first swarm's draws
    plan = opt.update_nominal_knots(knots, rewards)
    consensus = np.tensordot(softmax_weights(rewards, 0.5), knots, axes=1)
    np.testing.assert_allclose(plan, consensus)
    d = knots[1:] - consensus
    xi = check.standard_normal((7, 3, 2))
    expected = knots[1:] - 2.0 * 0.25 * d + np.sqrt(0.25 * 0.25 * d**2 + 0.01) * xi
    np.testing.assert_allclose(opt.particles, expected)
    again = opt.sample_control_knots(plan)
    np.testing.assert_array_equal(again[0], plan)
    np.testing.assert_array_equal(again[1:], opt.particles)  # the swarm is what is evaluated next


def test_the_swarm_contracts_onto_the_optimum_of_a_quadratic():
    """With no noise floor and a temperature far below the rewards' spread, the consensus finds the
    optimum."""
    opt = make(num_rollouts=64, num_nodes=2, sigma=1.0, sigma_min=0.0, temperature=0.001)
    target = np.array([[0.3, -0.2], [0.1, 0.4]])
    nominal = np.zeros((2, 2))
    for _ in range(100):
        knots = opt.sample_control_knots(nominal)
        nominal = opt.update_nominal_knots(knots, -np.square(knots - target).sum(axis=(1, 2)))
    np.testing.assert_allclose(nominal, target, atol=0.03)
    assert np.abs(opt.particles - target).max() < 0.1


def test_minus_inf_particles_get_no_weight_and_stay_finite():
    opt = make(num_rollouts=5, num_nodes=2, temperature=1e9)
    knots = opt.sample_control_knots(np.zeros((2, 2)))
    knots[2] = 40.0
    plan = opt.update_nominal_knots(knots, np.array([0.0, 1.0, -np.inf, 2.0, 3.0]))
    np.testing.assert_allclose(plan, knots[[0, 1, 3, 4]].mean(axis=0), rtol=1e-6)
    assert np.isfinite(opt.particles).all()


def test_the_swarm_shifts_with_the_knots_and_resizes_with_num_rollouts():
    opt = make(num_rollouts=6, num_nodes=3)
    knots = opt.sample_control_knots(np.zeros((3, 2)))
    opt.update_nominal_knots(knots, -np.abs(knots).sum(axis=(1, 2)))
    swarm = opt.particles.copy()
    old_times, new_times = np.linspace(0.0, 1.0, 3), np.linspace(0.1, 1.1, 4)
    opt.num_nodes = 4
    opt.pre_optimization(old_times, new_times)
    np.testing.assert_allclose(opt.particles, shift_knots(swarm, old_times, new_times))
    opt.num_rollouts = 9  # three new particles around the plan
    grown = opt.sample_control_knots(np.zeros((4, 2)))
    np.testing.assert_array_equal(grown[1:6], opt.particles)
    opt.num_rollouts = 3
    assert opt.sample_control_knots(np.zeros((4, 2))).shape == (3, 4, 2)


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(
        judo.ConfigError,
        match=r"^CBO needs num_rollouts >= 2 \(the "
        r"plan plus a particle\), got 1$",
    ):
        CBOConfig(num_rollouts=1)
    with pytest.raises(
        judo.ConfigError,
        match=r"^step_size must be above "
        r"0 and at most 1, got 0.0$",
    ):
        CBOConfig(step_size=0.0)
    with pytest.raises(judo.ConfigError, match=r"^sigma_min must be non-negative, got -0.1$"):
        CBOConfig(sigma_min=-0.1)


def test_it_is_registered_for_the_cli_and_the_gui():
    assert judo.get_registered_optimizers()["cbo"] == (CBO, CBOConfig)


@pytest.mark.slow
def test_it_plans_through_robust_planning_proposals_and_a_low_level_policy():
    controller = plan_with_everything("cbo")
    assert np.isfinite(controller.rewards).all() and controller.rewards.shape == (16,)
    assert np.abs(controller.nominal_knots).max() <= controller.task.command_range[0, 1]


@pytest.mark.slow
@pytest.mark.parametrize("task_name", ["pendulum", "cartpole"])
def test_it_swings_up_in_closed_loop(task_name):
    assert swing_up_metric(task_name, "cbo") > 0.9
