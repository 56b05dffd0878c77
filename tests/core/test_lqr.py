import mujoco
import numpy as np
import pytest

from judo.core.lqr import capped_cost_to_go, lqr_cost_to_go
from judo.tasks.double_cartpole import MODEL_PATH as DOUBLE_CARTPOLE

UPRIGHT_PENDULUM = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 1" size="0.05" mass="1"/>
    </body>
  </worldbody>
  {actuator}
</mujoco>
"""


def linearisation(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    a, b = np.zeros((2 * model.nv, 2 * model.nv)), np.zeros((2 * model.nv, model.nu))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, a, b, None, None)
    return a, b


def test_cost_to_go_of_the_double_cartpole_is_positive_definite_and_its_gain_stabilises_upright() -> (  # noqa: E501
    None
):
    model = mujoco.MjModel.from_xml_path(str(DOUBLE_CARTPOLE))
    p = lqr_cost_to_go(model, np.array([1.0, 1.0, 1.0, 0.1, 0.1, 0.1]), 1.0)
    assert p.shape == (6, 6)
    np.testing.assert_allclose(p, p.T)
    assert np.all(np.linalg.eigvalsh(p) > 0)
    a, b = linearisation(model)
    assert np.max(np.abs(np.linalg.eigvals(a))) > 1.0  # upright is unstable on its own
    gain = np.linalg.solve(np.eye(1) + b.T @ p @ b, b.T @ p @ a)
    assert np.max(np.abs(np.linalg.eigvals(a - b @ gain))) < 1.0  # and stable under the LQR gain


def test_cost_to_go_rejects_bad_weights_free_joints_and_a_pose_no_actuator_can_hold() -> None:
    pendulum = mujoco.MjModel.from_xml_string(
        UPRIGHT_PENDULUM.format(actuator='<actuator><motor joint="hinge"/></actuator>')
    )
    assert lqr_cost_to_go(pendulum, np.array([1.0, 0.1]), 1.0).shape == (2, 2)
    with pytest.raises(ValueError, match="2 \\* nv = 2 entries"):
        lqr_cost_to_go(pendulum, np.ones(3), 1.0)
    free = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>'
    )
    with pytest.raises(ValueError, match="nq=7, nv=6"):
        lqr_cost_to_go(free, np.ones(12), 1.0)
    unactuated = mujoco.MjModel.from_xml_string(UPRIGHT_PENDULUM.format(actuator=""))
    with pytest.raises(ValueError, match="cannot stabilise its rest pose"):
        lqr_cost_to_go(unactuated, np.array([1.0, 0.1]), 1.0)


def test_capped_cost_is_zero_at_rest_quadratic_near_it_and_saturates_at_one() -> None:
    matrix = np.diag([2.0, 1.0])
    deviations = np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 100.0]]])  # (1, 4, 2)
    cost = capped_cost_to_go(deviations, matrix, saturation=10.0)
    assert cost.shape == (1, 4)
    np.testing.assert_allclose(cost, [[0.0, 0.2, 0.8, 1.0]])


def test_capped_cost_wraps_the_angle_columns_only() -> None:
    matrix = np.diag([2.0, 1.0])
    turned = np.array([2 * np.pi + 1.0, 0.0])
    assert capped_cost_to_go(turned, matrix, saturation=10.0, angle_columns=[0]) == pytest.approx(
        0.2
    )
    assert capped_cost_to_go(turned, matrix, saturation=10.0) == 1.0  # unwrapped: far from rest
    assert turned[0] == 2 * np.pi + 1.0  # the caller's array is left as it was
