"""mtp: the path matrices, tensor samples over the command range, the elite refit with momentum,
carried state, and closed-loop swing-ups."""

import numpy as np
import pytest
from closed_loop import plan_with_everything, swing_up_metric

import judo
from judo.optimizers.knot_shift import shift_knots
from judo.optimizers.mppi import softmax_weights
from judo.optimizers.mtp import MTP, MTPConfig, bspline_basis, path_matrix


def make(nu: int = 2, seed: int = 0, **fields) -> MTP:
    optimizer = MTP(MTPConfig(**fields), nu)
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


@pytest.mark.parametrize("smoothing", ["linear", "bspline"])
def test_path_matrices_are_convex_and_go_through_the_end_waypoints(smoothing):
    matrix = path_matrix(7, 4, smoothing)
    assert matrix.shape == (7, 4) and (matrix >= 0).all()
    np.testing.assert_allclose(matrix.sum(axis=1), 1.0)
    np.testing.assert_allclose(matrix[0], [1, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(matrix[-1], [0, 0, 0, 1], atol=1e-12)


def test_linear_paths_interpolate_the_waypoints_and_the_bspline_matches_de_casteljau():
    np.testing.assert_allclose(
        path_matrix(5, 3, "linear") @ [0.0, 1.0, 0.0], [0.0, 0.5, 1.0, 0.5, 0.0]
    )
    x = np.linspace(0.0, 1.0, 9)  # three control points, degree 2: a quadratic Bezier curve
    bezier = np.stack([(1 - x) ** 2, 2 * x * (1 - x), x**2], axis=1)
    np.testing.assert_allclose(bspline_basis(x, 3, 2), bezier, atol=1e-12)


def test_samples_are_plan_best_tensor_then_local_within_the_command_range():
    opt = make(num_rollouts=21, num_nodes=4, tensor_fraction=0.5, graph_width=5)
    opt.command_range = np.array([[-1.0, 1.0], [0.0, 3.0]])
    nominal = np.full((4, 2), 0.5)
    knots = opt.sample_control_knots(nominal)
    np.testing.assert_array_equal(knots[0], nominal)
    tensor = knots[1:11]  # no best kept yet: half of the other 20 are tensor samples
    assert (tensor[..., 0] >= -1).all() and (tensor[..., 0] <= 1).all()
    assert (tensor[..., 1] >= 0).all() and (tensor[..., 1] <= 3).all()
    assert tensor[..., 1].std() > 0.4  # spread over the range, far wider than the local sigma
    rewards = -np.square(knots - 0.2).sum(axis=(1, 2))
    opt.update_nominal_knots(knots, rewards)
    again = opt.sample_control_knots(nominal)
    np.testing.assert_array_equal(again[1], knots[np.argmax(rewards)])  # the best is kept


def test_the_refit_follows_the_weighted_elites_with_momentum():
    opt = make(
        num_rollouts=16,
        num_nodes=3,
        num_elites=5,
        momentum=0.25,
        sigma_min=0.01,
        sigma_max=2.0,
        temperature=2.0,
    )
    nominal = np.zeros((3, 2))
    knots = opt.sample_control_knots(nominal)
    rewards = -np.abs(knots - 0.3).sum(axis=(1, 2))
    rewards[3] = -np.inf
    plan = opt.update_nominal_knots(knots, rewards)
    elites = np.argsort(-rewards)[:5]
    w = softmax_weights(rewards[elites], 2.0)
    mean = np.tensordot(w, knots[elites], axes=1)
    std = np.sqrt(np.tensordot(w, (knots[elites] - mean) ** 2, axes=1))
    np.testing.assert_allclose(plan, 0.75 * mean)
    np.testing.assert_allclose(
        opt.sigma, np.sqrt(0.25 * 2.0**2 + 0.75 * np.clip(std, 0.01, 2.0) ** 2)
    )
    assert 0.05 < std.min()  # the elites' spread is in the refit, not only the clip
    np.testing.assert_array_equal(opt.best, knots[elites[0]])


def test_minus_inf_rewards_never_become_elites():
    opt = make(num_rollouts=6, num_nodes=2, num_elites=6, temperature=1e9, momentum=0.0)
    knots = opt.sample_control_knots(np.zeros((2, 2)))
    knots[2] = 30.0
    plan = opt.update_nominal_knots(knots, np.array([0.0, 1.0, -np.inf, 2.0, -np.inf, 3.0]))
    np.testing.assert_allclose(plan, knots[[0, 1, 3, 5]].mean(axis=0), rtol=1e-6)
    assert np.isfinite(opt.sigma).all()


def test_unbounded_controls_span_the_nominal_and_state_shifts_between_cycles():
    opt = make(num_rollouts=40, num_nodes=3, tensor_fraction=1.0, sigma_max=0.5)
    opt.command_range = np.array([[-np.inf, np.inf], [-1.0, np.inf]])
    knots = opt.sample_control_knots(np.full((3, 2), 10.0))
    assert (np.abs(knots[1:, :, 0] - 10.0) <= 1.5).all() and (knots[1:, :, 1] >= -1.0).all()
    opt.update_nominal_knots(knots, -np.abs(knots - 10.2).sum(axis=(1, 2)))
    sigma, best = opt.sigma.copy(), opt.best.copy()
    old_times, new_times = np.linspace(0.0, 1.0, 3), np.linspace(0.2, 1.2, 5)
    opt.num_nodes = 5
    opt.pre_optimization(old_times, new_times)
    np.testing.assert_allclose(opt.sigma, shift_knots(sigma, old_times, new_times))
    np.testing.assert_allclose(opt.best, shift_knots(best, old_times, new_times))
    assert opt.sample_control_knots(np.zeros((5, 2))).shape == (40, 5, 2)


def test_bad_values_are_refused_with_a_clear_message():
    with pytest.raises(
        judo.ConfigError,
        match=r"^path_smoothing must be one of "
        r"\['linear', 'bspline'\], got 'akima'$",
    ):
        MTPConfig(path_smoothing="akima")  # type: ignore[arg-type]
    with pytest.raises(
        judo.ConfigError,
        match=r"^path_smoothing 'bspline' \(quadratic\) "
        r"needs num_waypoints >= 3, got 2$",
    ):
        MTPConfig(num_waypoints=2)
    with pytest.raises(
        judo.ConfigError,
        match=r"^momentum must be at least "
        r"0 and below 1, got 1.0$",
    ):
        MTPConfig(momentum=1.0)
    with pytest.raises(
        judo.ConfigError,
        match=r"^num_elites must be between 1 "
        r"and num_rollouts \(8\), got 9$",
    ):
        MTPConfig(num_rollouts=8, num_elites=9)
    assert MTPConfig(num_waypoints=2, path_smoothing="linear").num_waypoints == 2


def test_it_is_registered_for_the_cli_and_the_gui():
    assert judo.get_registered_optimizers()["mtp"] == (MTP, MTPConfig)


@pytest.mark.slow
def test_it_plans_through_robust_planning_proposals_and_a_low_level_policy():
    controller = plan_with_everything("mtp")
    assert np.isfinite(controller.rewards).all() and controller.rewards.shape == (16,)
    # the commands'
    np.testing.assert_array_equal(controller.optimizer.command_range, controller.task.command_range)
    assert np.abs(controller.nominal_knots).max() <= controller.task.command_range[0, 1]


@pytest.mark.slow
@pytest.mark.parametrize("task_name", ["pendulum", "cartpole"])
def test_it_swings_up_in_closed_loop(task_name):
    assert swing_up_metric(task_name, "mtp") > 0.9
