"""Mocap goals reach the rollouts: MuJoCo's rollout resets mocap poses unless they are passed as
inputs."""

import mujoco
import numpy as np

from judo.core.model import STATE_SPEC
from judo.core.rollouts.rollout import RolloutPool

GOAL_XML = """
<mujoco>
  <worldbody>
    <body name="ball"><joint name="x" type="slide" axis="1 0 0"/><geom size="0.1"/></body>
    <body name="goal" mocap="true" pos="0 0 1"><geom size="0.05" contype="0" conaffinity="0"/></body>
  </worldbody>
  <actuator><motor joint="x"/></actuator>
  <sensor>
    <framepos name="goal_pos" objtype="body" objname="goal"/>
    <framequat name="goal_quat" objtype="body" objname="goal"/>
  </sensor>
</mujoco>
"""  # noqa: E501


def test_rollouts_see_the_given_mocap_pose_at_every_step() -> None:
    model = mujoco.MjModel.from_xml_string(GOAL_XML)
    data = mujoco.MjData(model)
    initial = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial, STATE_SPEC)
    pool = RolloutPool(model, num_workers=2)
    goal_quat = np.array([0.0, 0.0, 0.0, 1.0])
    mocap = np.concatenate([[0.3, -0.2, 0.5], goal_quat])
    controls = np.ones((4, 5, 1))
    _, sensors = pool.rollout(initial, controls, mocap)
    np.testing.assert_allclose(sensors[..., :3], np.broadcast_to([0.3, -0.2, 0.5], (4, 5, 3)))
    np.testing.assert_allclose(sensors[..., 3:7], np.broadcast_to(goal_quat, (4, 5, 4)))
    _, sensors = pool.rollout(initial, controls)  # no mocap given: the model's own goal pose
    np.testing.assert_allclose(sensors[..., :3], np.broadcast_to([0.0, 0.0, 1.0], (4, 5, 3)))
    pool.close()


def test_mocap_inputs_leave_the_controls_unchanged() -> None:
    model = mujoco.MjModel.from_xml_string(GOAL_XML)
    data = mujoco.MjData(model)
    initial = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial, STATE_SPEC)
    pool = RolloutPool(model, num_workers=1)
    controls = np.linspace(-1, 1, 2 * 6).reshape(2, 6, 1)
    states_plain = pool.rollout(initial, controls)[0].copy()
    states_mocap = pool.rollout(initial, controls, np.array([0.0, 0, 0, 1, 0, 0, 0]))[0]
    np.testing.assert_array_equal(states_plain, states_mocap)
    pool.close()
