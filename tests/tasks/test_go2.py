"""The Go2 model keeps to the Unitree contract (names, motor order, PD gains, measured sensors, the
lying start), and its two tasks stand it up under pushes and take a velocity command from the CLI,
TOML and config."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.configuration.registry import default_configs, make_config
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.runtime import launch
from judo.tasks.unitree.go2 import JOINTS, LEGS, STAND_POSE, Go2Stand, Go2Walk, Go2WalkConfig

MOTOR_ORDER = [
    f"{leg}_{part}_joint" for leg in ("FR", "FL", "RR", "RL") for part in ("hip", "thigh", "calf")
]
"""Unitree's Go2 motors 0..11, written out here rather than taken from the module under test."""


def name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, kind, index) or ""


def test_actuators_are_unitree_s_motors_in_order_named_after_their_joints():
    model = Go2Stand().model
    assert list(JOINTS) == MOTOR_ORDER and model.nu == 12
    joints = [
        name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[i, 0]) for i in range(model.nu)
    ]
    assert joints == MOTOR_ORDER
    actuators = [name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(model.nu)]
    assert actuators == [joint.removesuffix("_joint") for joint in MOTOR_ORDER]
    assert (
        model.body(model.jnt_bodyid[0]).name == "base"
        and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    )


def test_position_actuators_carry_unitree_s_pd_and_the_motor_limits():
    model = Go2Stand().model
    kp, kd = model.actuator_gainprm[:, 0], -model.actuator_biasprm[:, 2]
    np.testing.assert_array_equal(kp, np.full(12, 60.0))
    np.testing.assert_array_equal(kd, np.full(12, 5.0))
    # a position servo: kp (q_des - q)
    np.testing.assert_array_equal(model.actuator_biasprm[:, 1], -kp)
    np.testing.assert_array_equal(model.actuator_forcerange[:, 1], np.tile([23.7, 23.7, 45.43], 4))
    assert model.actuator_forcelimited.all()
    joint_ranges = model.jnt_range[model.actuator_trnid[:, 0]]
    np.testing.assert_array_equal(model.actuator_ctrlrange, joint_ranges)


def test_measured_sensors_are_what_lowstate_carries_in_its_order():
    task = Go2Stand()
    expected = [
        *(f"{joint}_pos" for joint in MOTOR_ORDER),
        *(f"{joint}_vel" for joint in MOTOR_ORDER),
        "imu_quat",
        "imu_gyro",
        "imu_acc",
        *(f"foot_force_{leg}" for leg in ("FR", "FL", "RR", "RL")),
    ]
    assert list(task.measured_sensors) == expected
    types = (
        ["jointpos"] * 12
        + ["jointvel"] * 12
        + ["framequat", "gyro", "accelerometer"]
        + ["touch"] * 4
    )
    assert list(task.measured.types) == types
    model = task.model
    imu = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "imu")
    assert model.body(model.site_bodyid[imu]).name == "base"
    for sensor in ("imu_quat", "imu_gyro", "imu_acc"):
        assert model.sensor(sensor).objid[0] == imu
    for leg in LEGS:  # each foot's touch site sits on its calf, around the foot sphere
        site = model.sensor(f"foot_force_{leg}").objid[0]
        assert model.body(model.site_bodyid[site]).name == f"{leg}_calf"
    assert task.default_estimator in judo.get_registered_estimators()


def test_the_lying_start_is_unitree_s_stand_down_pose_resting_on_the_floor():
    task = Go2Stand()
    task.reset()
    np.testing.assert_allclose(task.data.qpos[7:], np.tile([0.0, 1.36, -2.65], 4), atol=0.1)
    # the servos hold the pose
    np.testing.assert_array_equal(task.data.ctrl, np.tile([0.0, 1.36, -2.65], 4))
    for _ in range(100):  # held in the pose, it stays where it lies
        mujoco.mj_step(task.sim_model, task.data)
    assert task.data.qpos[2] < 0.12 and np.abs(task.data.qvel).max() < 0.05


def test_the_feet_s_touch_sensors_carry_the_robot_s_weight_when_it_stands():
    task = Go2Walk()  # starts in the crouched stand
    task.data.ctrl[:] = STAND_POSE
    for _ in range(50):
        mujoco.mj_step(task.sim_model, task.data)
    weight = mujoco.mj_getTotalmass(task.sim_model) * 9.81
    forces = task.data.sensordata[task.sim_measured.columns[-4:]]
    assert forces.sum() == pytest.approx(weight, rel=0.05) and (forces > 0.1 * weight).all()


def test_the_safe_action_is_the_crouched_stand_and_holds_the_robot_up_from_lying():
    task = Go2Stand()
    task.reset()
    state = np.concatenate([task.data.qpos, task.data.qvel])
    # not the current joint angles
    np.testing.assert_array_equal(task.safe_action(state), STAND_POSE)
    task.data.ctrl[:] = task.safe_action(state)
    for _ in range(200):
        mujoco.mj_step(task.sim_model, task.data)
    assert task.data.qpos[2] > 0.22, f"the crouch left the base at {task.data.qpos[2]:.3f} m"


def test_pushes_shove_the_plant_s_base_on_schedule():
    task = Go2Stand()
    task.config.push_force, task.config.push_interval, task.config.push_duration = 50.0, 0.5, 0.1
    task.rng = np.random.default_rng(0)
    task.reset()
    base = task.sim_model.body("base").id
    pushed = []
    for _ in range(120):
        task.pre_sim_step()
        pushed.append(np.linalg.norm(task.data.xfrc_applied[base, :3]))
        mujoco.mj_step(task.sim_model, task.data)
    pushed = np.array(pushed)
    assert task.pushes.count == 2 and pushed.max() == pytest.approx(50.0)
    assert 15 <= (pushed > 0).sum() <= 25  # two pushes of about 0.1 s at 0.01 s a step


def test_velocity_command_parses_from_the_command_line():
    argv = [
        "--task",
        "go2_walk",
        "--optimizer",
        "mppi",
        "--task-config.velocity-command",
        "0.5",
        "0",
        "-0.3",
    ]
    _, configs = launch.parse(argv, default_configs("go2_walk", "mppi"))
    np.testing.assert_array_equal(configs["task"].velocity_command, [0.5, 0.0, -0.3])


def test_velocity_command_parses_from_toml(tmp_path):
    path = tmp_path / "walk.toml"
    path.write_text("[task_config_overrides.go2_walk]\nvelocity_command = [0.3, 0.1, 0.2]\n")
    judo.load_config(path)
    np.testing.assert_array_equal(
        make_config(Go2WalkConfig, "go2_walk").velocity_command, [0.3, 0.1, 0.2]
    )
    path.write_text("[task_config_overrides.go2_walk]\nvelocity_command = [0.3, 0.1]\n")
    with pytest.raises(judo.JudoError, match="velocity_command expects 3 numbers"):
        judo.load_config(path)


def test_walk_metrics_compare_the_heading_frame_velocity_with_the_command():
    task = Go2Walk()
    task.config.velocity_command = np.array([0.4, 0.0, 0.0])
    yaw = np.pi / 2  # facing +y, moving +y at 0.4 m/s: on command
    task.data.qpos[3:7] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    task.data.qvel[1] = 0.4
    mujoco.mj_forward(task.sim_model, task.data)
    steps = 200
    log = EpisodeLog(
        times=task.dt * np.arange(1, steps + 1),
        states=np.tile(np.concatenate([task.data.qpos, task.data.qvel]), (steps, 1)),
        controls=np.zeros((steps, 12)),
        sensors=np.tile(task.data.sensordata, (steps, 1)),
    )
    metrics = task.metrics(log)
    assert metrics["velocity_error"] == pytest.approx(0.0, abs=1e-9)
    assert metrics["yaw_rate_error"] == pytest.approx(0.0, abs=1e-9)
    assert metrics["standing_fraction"] == 1.0 and metrics["falls"] == 0.0


@pytest.mark.slow
def test_with_its_defaults_it_stands_up_from_lying_and_holds_the_height():
    controller = judo.make_controller("go2_stand", "mppi", seed=0, num_workers=1)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    assert plant.task.data.qpos[2] < 0.12
    with controller:
        result = run_episode(controller, plant, duration=2.0, seed=0)
    heights = result.log.sensors[:, plant.task.get_sensor_start_index("trace_base") + 2]
    assert heights[-50:].min() > 0.24, f"the base ended at {heights[-50:].min():.3f} m"
    assert result.metrics["time_to_stand"] < 1.0 and result.metrics["falls"] == 0.0
