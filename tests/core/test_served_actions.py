"""Served actions stay within the actuators' ctrlrange, and the rollouts are scored on exactly what
is served."""

import mujoco
import numpy as np
import pytest

import judo
from judo.optimizers.mppi import MPPI, MPPIConfig

PENDULUM_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="arm">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size=".03" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor joint="hinge" ctrlrange="-3 3" ctrllimited="true"/></actuator>
</mujoco>
"""


class SwingUp(judo.Task[judo.TaskConfig]):
    """A torque-limited pendulum that must swing up: the best plans sit on the torque limits."""

    def reward(self, states, sensors, controls, config, system_metadata=None):
        upright = np.cos(states[..., 0] - np.pi)
        return -(1.0 - upright).sum(-1) - 1e-3 * np.square(states[..., 1]).sum(-1)


@pytest.fixture
def swing_up(tmp_path):
    path = tmp_path / "pendulum.xml"
    path.write_text(PENDULUM_XML)
    return SwingUp(path)


def test_a_cubic_plan_never_serves_or_rolls_out_a_torque_beyond_the_range(swing_up):
    """The user's case: 6-knot cubic, ctrlrange -3 3, 10 s closed loop at 20 Hz (200 control
    periods)."""
    config = judo.ControllerConfig(horizon=1.0, spline_order="cubic", control_freq=20.0)
    optimizer = MPPI(
        MPPIConfig(num_rollouts=16, num_nodes=6, sigma=2.0, temperature=0.05), swing_up.nu
    )
    optimizer.rng = np.random.default_rng(0)
    controller = judo.Controller(config, swing_up, optimizer, num_workers=1)
    model, data = swing_up.model, mujoco.MjData(swing_up.model)
    steps_per_plan = round(1.0 / (config.control_freq * model.opt.timestep))
    served, rolled_out, cycles = [], [], 0
    try:
        for step in range(1000):
            if step % steps_per_plan == 0:
                controller.update_action(np.r_[data.qpos, data.qvel], data.time)
                rolled_out.append(np.abs(controller._layout.controls).max())
                cycles += 1
            for query in (data.time, data.time + 0.003, data.time + 0.007):  # between knots, too
                served.append(controller.action(query))
            data.ctrl[:] = served[-3]
            mujoco.mj_step(model, data)
    finally:
        controller.close()
    served = np.array(served)
    assert cycles == 200
    assert np.abs(served).max() <= 3.0, f"{(np.abs(served) > 3.0).sum()} served actions beyond +-3"
    assert max(rolled_out) <= 3.0
    assert np.isclose(np.abs(served).max(), 3.0)  # the case does push against the limit


def test_the_plan_serves_what_its_rollouts_applied(swing_up):
    """action(t) at every rollout step equals the nominal rollout's (index 0) controls, limits
    included."""
    config = judo.ControllerConfig(horizon=0.5, spline_order="cubic")
    optimizer = MPPI(MPPIConfig(num_rollouts=8, num_nodes=6, sigma=3.0), swing_up.nu)
    optimizer.rng = np.random.default_rng(1)
    controller = judo.Controller(config, swing_up, optimizer, num_workers=1)
    try:
        state = np.zeros(2)
        plan = controller.update_action(state, 0.0)
        knots = np.clip(plan.knots, -3, 3)
        # Roll the new plan's knots out the way the next cycle's nominal (entry 0) is rolled out.
        optimizer.sample_control_knots = lambda nominal: np.repeat(knots[None], 8, axis=0)  # type: ignore[method-assign]
        controller.update_action(state, 0.0)
        times = np.arange(controller.num_steps) * swing_up.dt
        np.testing.assert_array_equal(plan(times), controller._layout.controls[0])
        assert np.abs(controller._layout.controls).max() <= 3.0
    finally:
        controller.close()


def test_a_bounded_spline_clamps_scalar_and_array_queries():
    basis = judo.SplineBasis(np.linspace(0.0, 1.0, 6), "cubic")
    knots = np.array([[3.0], [-3.0], [3.0], [-3.0], [3.0], [-3.0]])
    # the overshoot
    assert np.abs(judo.Spline(0.0, basis, knots)(np.linspace(0, 1, 101))).max() > 3.5
    spline = judo.Spline(0.0, basis, knots, low=np.array([-3.0]), high=np.array([3.0]))
    values = spline(np.linspace(0, 1, 101))
    assert values.min() == -3.0 and values.max() == 3.0
    assert all(-3.0 <= spline(t)[0] <= 3.0 for t in np.linspace(0, 1, 101))


def test_a_linear_spline_is_clamped_only_when_its_knots_leave_the_bounds():
    basis = judo.SplineBasis(np.linspace(0.0, 1.0, 3), "linear")
    inside = judo.Spline(
        0.0, basis, np.array([[1.0], [-1.0], [1.0]]), low=np.array([-1.0]), high=np.array([1.0])
    )
    np.testing.assert_allclose(inside(np.array([0.25, 0.5])), [[0.0], [-1.0]])
    outside = judo.Spline(
        0.0, basis, np.array([[5.0], [-5.0], [5.0]]), low=np.array([-1.0]), high=np.array([1.0])
    )
    np.testing.assert_allclose(outside(np.array([0.1, 0.25, 0.5])), [[1.0], [0.0], [-1.0]])
    assert outside(0.5)[0] == -1.0


def test_a_non_finite_reading_is_refused_and_never_served(swing_up):
    """A sensor that returns NaN must not reach the rollouts (MuJoCo floods its log) or the served
    action."""
    controller = judo.Controller(
        judo.ControllerConfig(horizon=0.3),
        swing_up,
        MPPI(MPPIConfig(num_rollouts=4), swing_up.nu),
        num_workers=1,
    )
    try:
        plan = controller.update_action(np.zeros(2), 0.0)
        with pytest.raises(
            judo.JudoError,
            match=r"non-finite reading \(non-finite "
            r"state entries \[1\]\)",
        ):
            controller.update_action(np.array([0.0, np.nan]), 0.01)
        with pytest.raises(
            judo.JudoError, match="action time must be a finite number of seconds, got nan"
        ):
            controller.action(float("nan"))
        # the previous plan is still served
        np.testing.assert_array_equal(controller.action(0.1), plan(0.1))
    finally:
        controller.close()
