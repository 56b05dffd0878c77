"""The legged estimator on a tiny four-legged robot: the base's height, attitude and velocity from
the IMU, the encoders and the foot contacts, against the simulated truth; and the one-line errors
for a model it cannot read."""

import mujoco
import numpy as np
import pytest

from judo.core.configuration.registry import make_estimator
from judo.core.errors import ConfigError
from judo.core.estimator import ControlHistory
from judo.core.task import Task
from judo.estimators.legged import LeggedConfig, LeggedEstimator
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem

LEG = """
      <body name="{n}_thigh" pos="{x} {y} 0">
        <joint name="{n}_hip" axis="0 1 0" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.15" size="0.015" mass="0.2"/>
        <body name="{n}_shin" pos="0 0 -0.15">
          <joint name="{n}_knee" axis="0 1 0" range="-2.5 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.15" size="0.012" mass="0.1"/>
          <geom type="sphere" pos="0 0 -0.15" size="0.02" mass="0.05" friction="1.2"/>
          <site name="{n}_foot" pos="0 0 -0.15" size="0.025"/>
        </body>
      </body>"""
LEGS = (("FR", 0.15, -0.1), ("FL", 0.15, 0.1), ("RR", -0.15, -0.1), ("RL", -0.15, 0.1))
JOINTS = tuple(f"{leg}_{joint}" for leg, _, _ in LEGS for joint in ("hip", "knee"))
POSE = "0.359 -1.07 0.359 -1.07 0.358 -1.074 0.358 -1.074"
ROBOT_XML = f"""
<mujoco>
  <option timestep="0.005"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="base" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.2 0.1 0.04" mass="3"/>
      <site name="imu" pos="0.02 0 0.03" quat="0 0 0 1"/>
      {"".join(LEG.format(n=n, x=x, y=y) for n, x, y in LEGS)}
    </body>
  </worldbody>
  <actuator>{"".join(f'<position joint="{j}" kp="150" kv="2"/>' for j in JOINTS)}</actuator>
  <sensor>
    {"".join(f'<jointpos name="{j}_pos" joint="{j}"/>' for j in JOINTS)}
    {"".join(f'<jointvel name="{j}_vel" joint="{j}"/>' for j in JOINTS)}
    <framequat name="imu_quat" objtype="site" objname="imu"/>
    <gyro name="imu_gyro" site="imu"/>
    <accelerometer name="imu_acc" site="imu"/>
    {"".join(f'<touch name="{n}_touch" site="{n}_foot"/>' for n, _, _ in LEGS)}
  </sensor>
  <keyframe>
    <key qpos="0 0 0.2728 1 0 -0.0017 0 {POSE}" ctrl="{" 0.6 -1.2" * 4}"/>
  </keyframe>
</mujoco>
"""
"""A 4.6 kg robot standing on four point feet, with a turned IMU off the base's origin (the
estimator must take the site's rotation off), encoders, joint speeds and a touch sensor in each
foot."""
POSITIONS = tuple(f"{j}_pos" for j in JOINTS)
VELOCITIES = tuple(f"{j}_vel" for j in JOINTS)
IMU = ("imu_quat", "imu_gyro", "imu_acc")
TOUCH = tuple(f"{n}_touch" for n, _, _ in LEGS)
NOISE = {
    "jointpos": 0.005,
    "jointvel": 0.1,
    "framequat": float(np.deg2rad(0.5)),
    "gyro": 0.01,
    "accelerometer": 0.1,
}
"""A robot's sensors (the touch sensors' 5 N is added where they are measured)."""


def robot_task(tmp_path, sensors, xml=ROBOT_XML):
    path = tmp_path / "robot.xml"
    path.write_text(xml)

    class Robot(Task):
        measured_sensors = sensors

        def __init__(self) -> None:
            super().__init__(path)
            mujoco.mj_resetDataKeyframe(self.sim_model, self.data, 0)
            mujoco.mj_forward(self.sim_model, self.data)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(len(states))

    return Robot


SWAY = 0.12 * np.tile([1.0, -2.0], 4)
"""(8,) each joint's sway about the pose (rad): the knees twice the hips, the opposite way, so the
base bobs."""
SWAY_PHASE = np.repeat([0.0, 0.0, np.pi / 2, np.pi / 2], 2)
"""(8,) the rear legs a quarter cycle after the front: the base pitches too."""


def run(tmp_path, sensors, steps=400, config=None, delay=0.0, push=10.0):
    """(steps, 4) per step: |height error| (m), attitude error (deg), |velocity error| (m/s), planar
    distance (m), the robot bobbing and pitching at 1.5 Hz and pushed sideways (`push` N) for 0.2 s
    from 1 s on; the first 0.25 s left out."""
    robot = robot_task(tmp_path, sensors)
    plant, planner = robot(), robot()
    noise = {**NOISE, "touch": 5.0}
    system = SensedSystem(
        MujocoSystem(plant), noise=noise, delay=delay, rng=np.random.default_rng(0)
    )
    estimator = LeggedEstimator(planner, config or LeggedConfig(contact_force=3.0))
    controls = ControlHistory(planner.nu)
    estimator.reset(system.read_state())
    home = plant.model.key_ctrl[0]
    rows = []
    for k in range(steps):
        t = k * plant.sim_model.opt.timestep
        action = home + SWAY * np.sin(2 * np.pi * 1.5 * t + SWAY_PHASE)
        plant.data.xfrc_applied[1, 1] = push if 1.0 <= t < 1.2 else 0.0
        controls.append(system.time, action)
        system.apply(action)
        system.step()
        state = estimator.update(system.read_state(), system.time, controls).state
        truth = np.concatenate([plant.data.qpos, plant.data.qvel])
        rotation = np.zeros(3)
        mujoco.mju_subQuat(rotation, state[3:7], truth[3:7])
        if t >= 0.25:
            rows.append(
                (
                    abs(state[2] - truth[2]),
                    np.rad2deg(np.linalg.norm(rotation)),
                    np.linalg.norm(state[15:18] - truth[15:18]),
                    np.linalg.norm(state[:2] - truth[:2]),
                )
            )
    return np.array(rows)


def test_a_swaying_pushed_robot_keeps_its_height_attitude_and_velocity(tmp_path):
    errors = run(tmp_path, POSITIONS + VELOCITIES + IMU + TOUCH)
    mean, worst = errors.mean(axis=0), errors.max(axis=0)
    # Measured: height 0.7 (2.3) mm, attitude 0.27 (0.70) deg, velocity 0.046 (0.18) m/s, drift 13
    # mm.
    assert mean[0] < 0.003 and worst[0] < 0.01, (mean, worst)  # m
    # deg: the IMU's 0.5 deg per axis, smoothed
    assert mean[1] < 0.6 and worst[1] < 1.5, (mean, worst)
    assert mean[2] < 0.1 and worst[2] < 0.35, (mean, worst)  # m/s: the base swings at up to 0.4 m/s
    assert errors[-1, 3] < 0.06, errors[-1]  # m: the plane drifts, slowly


def test_without_touch_sensors_or_joint_speeds_the_lowest_feet_stand_and_the_encoders_are_differenced(  # noqa: E501
    tmp_path,
):
    errors = run(tmp_path, POSITIONS + IMU)
    mean, worst = errors.mean(axis=0), errors.max(axis=0)
    # Measured: height 1.2 (4.3) mm, attitude 0.27 (0.70) deg, velocity 0.11 (0.17) m/s.
    assert mean[0] < 0.004 and worst[0] < 0.015, (mean, worst)
    assert mean[1] < 0.6 and worst[1] < 1.5, (mean, worst)
    assert mean[2] < 0.2 and worst[2] < 0.4, (mean, worst)


def test_late_readings_are_carried_to_the_plant_s_now(tmp_path):
    errors = run(tmp_path, POSITIONS + VELOCITIES + IMU + TOUCH, delay=0.01)
    mean = errors.mean(axis=0)  # measured: 0.8 mm, 0.28 deg, 0.039 m/s
    assert mean[0] < 0.003 and mean[1] < 0.6 and mean[2] < 0.1, mean


def test_a_robot_at_rest_is_estimated_at_rest_on_the_floor_exactly(tmp_path):
    robot = robot_task(tmp_path, POSITIONS + VELOCITIES + IMU + TOUCH)
    plant, planner = robot(), robot()
    system = SensedSystem(MujocoSystem(plant))
    estimator = make_estimator("legged", planner, LeggedConfig(contact_force=3.0))
    controls = ControlHistory(planner.nu)
    estimator.reset(system.read_state())
    for _ in range(200):
        system.apply(plant.model.key_ctrl[0])
        system.step()
        state = estimator.update(system.read_state(), system.time, controls).state
    assert abs(state[2] - plant.data.qpos[2]) < 0.003  # m: the feet sink into the floor by less
    np.testing.assert_allclose(state[3:7], plant.data.qpos[3:7], atol=1e-9)
    np.testing.assert_allclose(state[7:15], plant.data.qpos[7:15], atol=1e-12)
    assert np.linalg.norm(state[15:18]) < 0.01  # m/s
    assert abs(np.linalg.norm(state[3:7]) - 1.0) < 1e-9


def test_a_task_without_what_the_estimator_needs_is_one_line_naming_it(tmp_path):
    with pytest.raises(ConfigError, match="needs an IMU .* found \\['framequat', 'gyro'\\]"):
        LeggedEstimator(robot_task(tmp_path, POSITIONS + IMU[:2])())
    with pytest.raises(
        ConfigError, match="needs a jointpos sensor of every joint .* none measures RL_hip, RL_knee"
    ):
        LeggedEstimator(robot_task(tmp_path, POSITIONS[:6] + IMU)())
    with pytest.raises(
        ConfigError, match="foot_sites \\['paw'\\] are not sites of Robot; its sites are \\['imu', "
    ):
        LeggedEstimator(robot_task(tmp_path, POSITIONS + IMU)(), LeggedConfig(foot_sites=("paw",)))
    fixed = ROBOT_XML.replace("<freejoint/>", "").replace(
        f'qpos="0 0 0.2728 1 0 -0.0017 0 {POSE}"', f'qpos="{POSE}"'
    )
    with pytest.raises(
        ConfigError, match="needs a model with one floating base \\(a free joint\\); Robot's has 0"
    ):
        LeggedEstimator(robot_task(tmp_path, POSITIONS + IMU, fixed)())
    with pytest.raises(ConfigError, match="LeggedConfig.ground_std must be positive, got -1"):
        LeggedConfig(ground_std=-1.0).validate()


def test_feet_default_to_the_touch_sensors_sites_and_stand_above_their_spheres(tmp_path):
    estimator = LeggedEstimator(robot_task(tmp_path, POSITIONS + IMU + TOUCH)())
    names = [
        mujoco.mj_id2name(estimator.model, mujoco.mjtObj.mjOBJ_SITE, s)
        for s in estimator.layout.feet
    ]
    assert names == ["FR_foot", "FL_foot", "RR_foot", "RL_foot"]
    # the site at the sphere's centre
    np.testing.assert_allclose(estimator.layout.ground_offset, 0.02)
    assert estimator.layout.touch is not None and estimator.layout.joint_vel is None
