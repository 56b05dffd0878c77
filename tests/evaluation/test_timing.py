import mujoco
import numpy as np

from judo.core.model import STATE_SPEC
from judo.evaluation.timing import rollout_start

MOCAP_XML = """
<mujoco>
  <worldbody>
    <body name="goal" mocap="true"><geom type="sphere" size="0.05" contype="0" conaffinity="0"/></body>
    <body><joint name="x" type="slide" axis="1 0 0"/><geom type="box" size="0.1 0.1 0.1"/></body>
  </worldbody>
</mujoco>
"""  # noqa: E501


def test_rollout_start_carries_the_state_time_and_mocap_pose():
    model = mujoco.MjModel.from_xml_string(MOCAP_XML)
    metadata = {
        "mocap_pos": np.array([[0.1, 0.2, 0.3]]),
        "mocap_quat": np.array([[0.0, 1.0, 0.0, 0.0]]),
    }
    initial, mocap = rollout_start(model, np.array([0.4, -0.5]), 2.5, metadata)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, initial, STATE_SPEC)
    assert (data.time, data.qpos[0], data.qvel[0]) == (2.5, 0.4, -0.5)
    assert mocap.tolist() == [0.1, 0.2, 0.3, 0.0, 1.0, 0.0, 0.0]
