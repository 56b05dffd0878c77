"""The bridge's messages are ROS 2's: their CDR bytes decode with rosbags' ROS 2 typestore (an
independent implementation) into the same values, and an MCAP log opens with mcap's ROS 2 reader."""

import numpy as np
import pytest

pytest.importorskip("cyclonedds")
rosbags_typesys = pytest.importorskip("rosbags.typesys")

import mujoco  # noqa: E402

from judo.core.errors import JudoError  # noqa: E402
from judo.ros2 import link  # noqa: E402
from judo.ros2 import messages as msg  # noqa: E402
from judo.ros2.joints import JointLayout, base_from_odometry  # noqa: E402
from judo.ros2.mcap_log import McapLog  # noqa: E402

FREE_BODY = """
<mujoco><worldbody>
  <body name="base"><freejoint name="root"/><geom size="0.1"/>
    <body name="leg"><joint name="knee" type="hinge"/><geom size="0.05" pos="0 0 -0.2"/></body>
  </body>
</worldbody></mujoco>
"""


def decoded(message):
    store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_HUMBLE)
    return store.deserialize_cdr(bytes(message.serialize()), msg.ROS_NAMES[type(message)])


def test_every_message_the_bridge_reads_or_writes_decodes_with_rosbags_into_the_same_values():
    model = mujoco.MjModel.from_xml_string(FREE_BODY)
    layout = JointLayout.of(model, ("knee=left_knee",))
    qpos = np.array([1.0, 2.0, 0.5, np.cos(0.3), 0.0, 0.0, np.sin(0.3), -0.4])  # yawed 0.6 rad
    qvel = np.array([0.5, -0.2, 0.1, 0.01, 0.02, 0.3, 1.5])

    joints = decoded(link.joint_state(layout, qpos, qvel, 12.25))
    assert (joints.header.stamp.sec, joints.header.stamp.nanosec) == (12, 250_000_000)
    assert list(joints.name) == ["left_knee"]
    assert joints.position.tolist() == [-0.4] and joints.velocity.tolist() == [1.5]

    odom = link.odometry(layout, qpos, qvel, 3.5)
    back = decoded(odom)
    assert (back.header.frame_id, back.child_frame_id) == ("odom", "base_link")
    q = back.pose.pose.orientation
    assert [q.w, q.x, q.y, q.z] == pytest.approx(qpos[3:7].tolist())
    assert [back.pose.pose.position.x, back.pose.pose.position.y, back.pose.pose.position.z] == [
        1.0,
        2.0,
        0.5,
    ]
    assert back.twist.twist.angular.z == 0.3 and len(back.pose.covariance) == 36
    # the body-frame twist back to MuJoCo's world frame
    base_qpos, base_qvel = base_from_odometry(odom)
    np.testing.assert_allclose(base_qpos, qpos[:7], atol=1e-12)
    np.testing.assert_allclose(base_qvel, qvel[:6], atol=1e-12)

    imu = decoded(link.imu(qpos, qvel, np.array([0.1, 0.2, 9.81]), layout, 3.5))
    assert imu.linear_acceleration.z == 9.81 and imu.angular_velocity.y == 0.02
    assert len(imu.orientation_covariance) == 9

    goal_pos, goal_quat = (
        np.array([[0.3, -0.2, 0.5], [1.0, 2.0, 3.0]]),
        np.array([[1.0, 0, 0, 0], [0, 0, 0, 1.0]]),
    )
    poses = link.mocap_poses(goal_pos, goal_quat, 2.0)
    mocap = decoded(poses)
    assert mocap.header.frame_id == "odom" and len(mocap.poses) == 2
    assert [mocap.poses[1].position.x, mocap.poses[1].orientation.z] == [1.0, 1.0]
    back_pos, back_quat = link.mocap_from_poses(poses, 2)
    np.testing.assert_array_equal(back_pos, goal_pos)
    np.testing.assert_array_equal(back_quat, goal_quat)
    with pytest.raises(
        JudoError, match="a PoseArray of 2 poses; expected the model's 1 mocap bodies"
    ):
        link.mocap_from_poses(poses, 1)
    poses.poses[0].position.x = float("nan")
    with pytest.raises(JudoError, match="non-finite position"):
        link.mocap_from_poses(poses, 2)

    commands = decoded(link.commands(np.array([0.25, -1.0])))
    assert commands.data.tolist() == [0.25, -1.0]
    assert (
        commands.layout.dim[0].label,
        commands.layout.dim[0].size,
        commands.layout.dim[0].stride,
    ) == (
        "actuators",
        2,
        2,
    )


def test_an_mcap_log_opens_with_mcaps_ros2_reader_with_its_topics_and_schemas(tmp_path):
    reader = pytest.importorskip("mcap_ros2.reader")
    log = McapLog(tmp_path / "run.mcap")
    model = mujoco.MjModel.from_xml_string(FREE_BODY)
    layout = JointLayout.of(model)
    qpos, qvel = np.array([0, 0, 0.5, 1, 0, 0, 0, 0.2]), np.zeros(7)
    log.write("/joint_states", link.joint_state(layout, qpos, qvel, 1.0), 1_000_000_000)
    log.write("/odom", link.odometry(layout, qpos, qvel, 1.0))
    log.write("/imu", link.imu(qpos, qvel, np.zeros(3), layout, 1.0))
    log.write("/judo/commands", link.commands(np.array([0.5])))
    log.write(
        "/judo/mocap",
        link.mocap_poses(np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0, 0, 0]]), 1.0),
    )
    log.close()
    seen = {
        m.channel.topic: (m.schema.name, m.ros_msg)
        for m in reader.read_ros2_messages(tmp_path / "run.mcap")
    }
    assert {topic: name for topic, (name, _) in seen.items()} == {
        "/joint_states": "sensor_msgs/msg/JointState",
        "/odom": "nav_msgs/msg/Odometry",
        "/imu": "sensor_msgs/msg/Imu",
        "/judo/commands": "std_msgs/msg/Float64MultiArray",
        "/judo/mocap": "geometry_msgs/msg/PoseArray",
    }
    assert seen["/judo/mocap"][1].poses[0].position.z == 1.0
    assert list(seen["/joint_states"][1].position) == [0.2]
    assert seen["/odom"][1].pose.pose.position.z == 0.5
    assert list(seen["/judo/commands"][1].data) == [0.5]


def test_the_estop_message_decodes_with_rosbags_as_std_msgs_bool():
    for data in (True, False):
        assert decoded(msg.Bool(data=data)).data is data
