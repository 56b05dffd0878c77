"""Feedback gains on the served plan: the TVLQR backward pass, the derivatives, serving, and failing
safely."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.feedback import FeedbackError, FeedbackGains, tvlqr_gains
from judo.core.feedback_plan import FeedbackPlan
from judo.core.model import STATE_SPEC
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.tasks.cartpole import Cartpole

MASS, TIMESTEP = 2.0, 0.01
SLIDER = f"""
<mujoco>
  <option timestep="{TIMESTEP}" gravity="0 0 0" integrator="Euler"/>
  <worldbody>
    <body>
      <joint name="slide" type="slide" axis="1 0 0" damping="{{damping}}"/>
      <geom type="sphere" size="0.1" mass="{MASS}"/>
    </body>
  </worldbody>
  <actuator><motor joint="slide" ctrlrange="-100 100"/></actuator>
</mujoco>
"""


def dare_gain(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The infinite-horizon discrete LQR gain K (u = K x) from the stable eigenvectors of the
    symplectic matrix, a method apart from the backward recursion."""
    n = len(a)
    a_inv_t = np.linalg.inv(a).T
    g = b @ np.linalg.solve(r, b.T)
    z = np.block([[a + g @ a_inv_t @ q, -g @ a_inv_t], [-a_inv_t @ q, a_inv_t]])
    values, vectors = np.linalg.eig(z)
    stable = vectors[:, np.abs(values) < 1.0]
    p = np.real(stable[n:] @ np.linalg.inv(stable[:n]))
    return -np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)


def initial_state(model: mujoco.MjModel, qpos: list[float], qvel: list[float]) -> np.ndarray:
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    return state


def test_gains_of_a_linear_system_match_the_discrete_riccati_solution() -> None:
    model = mujoco.MjModel.from_xml_string(SLIDER.format(damping=0))
    q, r = np.array([1.0, 0.1]), np.array([0.01])
    gains_of = FeedbackGains(None, num_workers=2, model=model)
    try:  # every step linearised: the exact per-step recursion
        start = initial_state(model, [0.0], [0.0])
        gains, nominal = gains_of.compute(
            start, np.zeros(0), np.zeros((2000, 1)), q, r, max_points=2000
        )
        # 5 steps each
        held, _ = gains_of.compute(
            start, np.zeros(0), np.zeros((2000, 1)), q, r, 400, exact_steps=0
        )
    finally:
        gains_of.close()
    # Euler on a free mass: v' = v + h u / m, x' = x + h v'.
    a = np.array([[1.0, TIMESTEP], [0.0, 1.0]])
    b = np.array([[TIMESTEP**2 / MASS], [TIMESTEP / MASS]])
    expected = dare_gain(a, b, np.diag(q), np.diag(r))
    assert gains.shape == (2000, 1, 2) and nominal.shape == (2000, 2)
    # no control: the nominal rests at the origin, where FD is exact
    np.testing.assert_array_equal(nominal, 0.0)
    np.testing.assert_allclose(gains[0], expected, rtol=1e-6, atol=1e-6)
    # The backward pass alone, on the exact matrices, converges to the same gain (20 s: long enough
    # to converge).
    exact = tvlqr_gains(np.repeat(a[None], 2000, 0), np.repeat(b[None], 2000, 0), q, r, q)
    np.testing.assert_allclose(exact[0], expected, rtol=1e-9, atol=1e-9)
    # A linearisation standing for 5 steps sets their one gain: the Riccati gain of the 5-step map
    # with the correction held, x -> A^5 x + (I + A + ... + A^4) B u, at 5 times the running cost.
    lifted_a = np.linalg.matrix_power(a, 5)
    lifted_b = sum(np.linalg.matrix_power(a, j) for j in range(5)) @ b
    expected_held = dare_gain(lifted_a, lifted_b, 5 * np.diag(q), 5 * np.diag(r))
    assert held.shape == (2000, 1, 2)
    np.testing.assert_array_equal(held[:5], np.repeat(held[:1], 5, axis=0))
    np.testing.assert_allclose(held[0], expected_held, rtol=1e-6, atol=1e-6)
    # a different law from the per-step one
    assert not np.allclose(expected_held, expected, rtol=1e-3)


def test_a_model_that_yields_nan_fails_with_a_named_error_and_nan_in_the_backward_pass_too() -> (
    None
):
    model = mujoco.MjModel.from_xml_string(SLIDER.format(damping=0))
    model.dof_damping[0] = np.nan
    gains_of = FeedbackGains(None, num_workers=1, model=model)
    with pytest.raises(FeedbackError, match="diverged|non-finite"):
        gains_of.compute(
            initial_state(model, [0.0], [0.0]),
            np.zeros(0),
            np.zeros((10, 1)),
            np.ones(2),
            np.ones(1),
        )
    gains_of.close()
    a = np.full((3, 2, 2), np.nan)
    with pytest.raises(FeedbackError, match="non-finite gains"):
        tvlqr_gains(a, np.ones((3, 2, 1)), np.ones(2), np.ones(1), np.ones(2))


def test_a_singular_backward_pass_is_a_feedback_error(monkeypatch: pytest.MonkeyPatch) -> None:
    # LAPACK calls a zero pivot singular (seen once on walker's held gains): the update's plan goes
    # without gains.
    def singular(*args: object) -> None:
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(np.linalg, "solve", singular)
    a, b = np.repeat(np.eye(2)[None], 3, 0), np.ones((3, 2, 1))
    with pytest.raises(FeedbackError, match="singular"):
        tvlqr_gains(a, b, np.ones(2), np.ones(1), np.ones(2))


def upright_loop(feedback_on_serve: bool) -> tuple[ClosedLoop, np.ndarray]:
    """A cartpole held upright by one plan (made from rest at upright, never replanned), its plant
    then pushed."""
    config = ControllerConfig(horizon=1.0, control_freq=0.2, feedback=True, max_plan_age=0.0)
    controller = judo.make_controller(
        "cartpole", "mppi", controller_config=config, num_workers=2, seed=0
    )
    plant = Cartpole()
    plant.data.qpos[:], plant.data.qvel[:] = [0.0, 0.0], [0.0, 0.0]
    mujoco.mj_forward(plant.sim_model, plant.data)
    system = MujocoSystem(plant)
    loop = ClosedLoop(controller, system)
    plan = loop.plan(loop.read())
    assert isinstance(plan, FeedbackPlan) and plan.gains is not None
    plant.data.qvel[1] = 0.6  # a push on the pole
    mujoco.mj_forward(plant.sim_model, plant.data)
    loop.read()
    if not feedback_on_serve:
        plan.gains = None  # the same plan, served open-loop
    angles = []
    for _ in range(100):  # 1 s, the plan's horizon
        record = loop.advance()
        angles.append(record.state[1])
    controller.close()
    return loop, np.abs(np.array(angles))


def test_on_cartpole_near_upright_the_gains_hold_a_push_that_the_open_loop_plan_does_not() -> None:
    _, with_gains = upright_loop(feedback_on_serve=True)
    _, open_loop = upright_loop(feedback_on_serve=False)
    assert with_gains.max() < 0.15, with_gains.max()  # rad: held near upright
    assert open_loop[-1] > 0.3, open_loop[-1]  # the same plan without gains lets the pole fall away


class NanCostCartpole(Cartpole):
    def feedback_cost(self) -> tuple[np.ndarray, np.ndarray]:
        state, control = super().feedback_cost()
        return state, np.full_like(control, np.nan)


def test_gains_are_finite_and_bounded_and_a_failed_update_serves_the_plan_without_them() -> None:
    config = ControllerConfig(horizon=0.5, feedback=True)
    state = np.array([0.0, 0.1, 0.0, 0.0])
    with judo.make_controller(
        "cartpole", "mppi", controller_config=config, num_workers=2, seed=1
    ) as controller:
        plan = controller.update_action(state, 0.0)
        assert (
            isinstance(plan, FeedbackPlan)
            and plan.feedback_error is None
            and plan.gains is not None
        )
        assert plan.gains.shape == (50, 1, 4) and np.isfinite(plan.gains).all()
        assert np.abs(plan.gains).max() < 1e3
        pushed = state + np.array([0.0, 0.05, 0.0, 0.0])
        corrected = plan(0.02, pushed)
        expected = plan(0.02) + plan.gains[2] @ (pushed - plan.nominal_states[2])
        np.testing.assert_allclose(corrected, np.clip(expected, *controller.task.command_range.T))
        far = plan(0.02, state + 100.0)
        low, high = controller.task.command_range.T
        assert np.all((far >= low) & (far <= high))  # clamped to the actuator range
        # (what serving with gains costs is a figure: benchmarks/feedback.py --timing-only prints
        # it)
    task = NanCostCartpole()
    optimizer = MPPI(MPPIConfig(num_rollouts=16), task.nu)
    with judo.Controller(config, task, optimizer, num_workers=2) as controller:
        plan = controller.update_action(state, 0.0)
        assert isinstance(plan, FeedbackPlan) and plan.gains is None
        assert plan.feedback_error == "feedback_cost's control weights must be finite and above 0"
        # the plan alone is served
        np.testing.assert_array_equal(plan(0.02, state + 0.05), plan(0.02))


def test_a_free_joint_s_deviation_is_taken_in_the_tangent_space() -> None:
    with judo.make_controller(
        "quadruped",
        "mppi",
        controller_config=ControllerConfig(feedback=True),
        num_workers=2,
        seed=0,
    ) as controller:
        controller.task.reset()
        data = controller.task.data
        state = np.concatenate([data.qpos, data.qvel])
        plan = controller.update_action(state, 0.0, controller.task.get_sim_metadata())
        assert (
            isinstance(plan, FeedbackPlan)
            and plan.gains is not None
            and plan.nominal_states is not None
        )
        # 3 + 3 for the free joint
        assert plan.gains.shape[1:] == (controller.task.nu, 2 * controller.task.model.nv)
        nominal = plan.nominal_states[0]
        np.testing.assert_allclose(plan(0.0, nominal), plan(0.0), atol=1e-12)
        flipped = nominal.copy()
        flipped[3:7] *= -1.0  # the same orientation: no deviation in the tangent space
        np.testing.assert_allclose(plan(0.0, flipped), plan(0.0), atol=1e-9)
        yawed = nominal.copy()
        mujoco.mj_integratePos(
            controller.task.model,
            yawed[: controller.task.model.nq],
            np.r_[0, 0, 0, 0, 0, 0.05, np.zeros(12)],
            1.0,
        )
        dx = np.zeros(2 * controller.task.model.nv)
        dx[5] = 0.05
        expected = np.clip(plan(0.0) + plan.gains[0] @ dx, *controller.task.command_range.T)
        np.testing.assert_allclose(plan(0.0, yawed), expected, atol=1e-9)
