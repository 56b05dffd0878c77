"""The quadruped model and its two tasks: the model stands, its sensors are the measured ones, the
gait schedule, the goal task walks towards a goal, and the velocity task's commands and policy
observation."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.errors import ConfigError
from judo.core.policy import PolicyError
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.gait import GAITS, LEGS, gait_of, swing_heights
from judo.tasks.quadruped import JOINTS, Quadruped, gravity_in_body
from judo.tasks.quadruped_velocity import COMMAND_KEY, QuadrupedVelocity, QuadrupedVelocityConfig


def test_the_model_has_go1_proportions():
    model = Quadruped().model
    assert (model.nq, model.nv, model.nu) == (19, 18, 12)
    assert 11.5 < model.body_subtreemass[model.body("torso").id] < 12.5  # Go1: about 12 kg
    for leg in LEGS:  # thigh and calf 0.213 m
        assert model.body(f"{leg}_calf").pos[2] == pytest.approx(-0.213)
        assert model.site(f"{leg}_foot").pos[2] == pytest.approx(-0.213)
    limits = np.abs(model.actuator_forcerange[:, 1]).reshape(4, 3)
    np.testing.assert_allclose(limits, np.tile([23.7, 23.7, 35.55], (4, 1)))


def test_it_stands_still_in_its_standing_pose_for_two_seconds():
    task = Quadruped()
    start = task.data.xpos[task.model.body("torso").id].copy()
    task.data.ctrl[:] = task.home_ctrl
    for _ in range(round(2.0 / task.dt)):
        mujoco.mj_step(task.sim_model, task.data)
    moved = np.linalg.norm(task.data.xpos[task.model.body("torso").id] - start)
    assert moved < 0.01, f"the trunk moved {moved:.4f} m"
    assert task.data.qpos[2] == pytest.approx(0.2976, abs=0.005)


def test_its_sensors_are_the_measured_ones():
    task = Quadruped()
    layout = task.measured
    assert layout.names[:12] == tuple(f"{joint}_pos" for joint in JOINTS)
    assert set(layout.types) == {"jointpos", "framequat", "gyro", "accelerometer", "touch"}
    mujoco.mj_forward(task.sim_model, task.data)
    values = layout.read(task.data.sensordata)
    # encoders read the joints
    np.testing.assert_allclose(values[:12], task.data.qpos[7:], atol=1e-12)
    accel = values[layout.slices[layout.names.index("imu_accel")]]
    # standing still: the accelerometer reads gravity
    assert accel[2] == pytest.approx(9.81, abs=0.3)
    touch = np.concatenate(
        [values[layout.slices[layout.names.index(f"{leg}_touch")]] for leg in LEGS]
    )
    # every foot carries its share
    assert np.all(touch > 20.0) and touch.sum() == pytest.approx(12.08 * 9.81, rel=0.05)


def test_the_trot_lifts_diagonal_pairs_together_and_stand_lifts_nothing():
    times = np.linspace(0.0, 2.0, 201)
    trot = swing_heights(times, GAITS["trot"], 0.07)  # (201, 4), legs FR FL RR RL
    np.testing.assert_allclose(trot[:, 0], trot[:, 3])
    np.testing.assert_allclose(trot[:, 1], trot[:, 2])
    assert np.all(np.minimum(trot[:, 0], trot[:, 1]) < 1e-9)  # the pairs never swing at once
    assert trot.max() == pytest.approx(0.07, abs=1e-3)
    walk = swing_heights(times, GAITS["walk"], 0.07)
    assert np.all((walk > 1e-9).sum(-1) <= 1)  # one foot at a time
    assert not swing_heights(times, GAITS["stand"], 0.07).any()
    with pytest.raises(ConfigError, match="expected one of \\['trot', 'walk', 'stand'\\]"):
        gait_of("gallop")


@pytest.mark.slow
def test_with_its_defaults_it_walks_towards_a_goal_a_metre_away():
    controller = judo.make_controller("quadruped", "mppi", seed=0, num_workers=1)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    task = plant.task
    assert isinstance(task, Quadruped) and task.goal_distance() == pytest.approx(1.0, abs=0.01)
    with controller:
        result = run_episode(controller, plant, duration=1.5, seed=0)
    assert task.goal_distance() < 0.5, f"still {task.goal_distance():.2f} m from the goal"
    assert result.metrics["falls"] == 0.0


def test_velocity_commands_are_seeded_redrawn_on_schedule_and_in_range():
    def commands(seed: int) -> list[np.ndarray]:
        task = QuadrupedVelocity()
        task.config = QuadrupedVelocityConfig(resample_period=1.0)
        task.rng = np.random.default_rng(seed)
        task.reset()
        for step in range(1, 501):  # 5 s of sim time; no physics needed for the schedule
            task.data.time = step * task.dt
            task.pre_sim_step()
        return [command for _, command in task.command_log]

    first, again, other = commands(3), commands(3), commands(4)
    assert len(first) == 6  # at 0, 1, 2, 3, 4 and 5 s
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)
    config = QuadrupedVelocityConfig()
    low = [-config.max_backward, -config.max_sideways, -config.max_yaw_rate]
    high = [config.max_forward, config.max_sideways, config.max_yaw_rate]
    assert np.all((np.array(first) >= low) & (np.array(first) <= high))


def test_a_manual_command_is_published_and_followed_by_the_reward():
    task = QuadrupedVelocity()
    task.config = QuadrupedVelocityConfig(manual=True, manual_vx=0.4, manual_yaw_rate=-0.2)
    task.data.time = 1.0
    task.pre_sim_step()
    np.testing.assert_array_equal(task.get_sim_metadata()[COMMAND_KEY], [0.4, 0.0, -0.2])
    mujoco.mj_forward(task.model, task.data)
    state = np.concatenate([task.data.qpos, task.data.qvel])
    states, sensors = np.tile(state, (2, 3, 1)), np.tile(task.data.sensordata, (2, 3, 1))
    controls = np.tile(task.home_ctrl, (2, 3, 1))
    still = task.reward(states, sensors, controls, task.config, {COMMAND_KEY: np.zeros(3)})
    asked = task.reward(states, sensors, controls, task.config, task.get_sim_metadata())
    assert np.all(asked < still)  # standing still misses a command to walk


def test_the_policy_observation_is_proprioception_and_command_without_the_previous_action():
    task = QuadrupedVelocity()
    state = np.concatenate([task.data.qpos, task.data.qvel])
    previous = np.tile(task.home_ctrl, (2, 1))
    previous[1, 0] += 0.1
    sensors = np.zeros((2, task.model.nsensordata))
    sensors[:, task._clock] = 0.1  # the sim time: a quarter of the trot's 0.4 s cycle
    observation = task.policy_observation(
        np.tile(state, (2, 1)), sensors, {COMMAND_KEY: [0.5, 0.1, 0.3]}, previous
    )
    assert observation.shape == (2, 35) == (2, task.policy_observation_size())
    # the clock: cos, sin
    np.testing.assert_allclose(observation[:, 33:35], [[0.0, 1.0]] * 2, atol=1e-12)
    with pytest.raises(PolicyError, match="needs the sensors, for the gait clock"):
        task.policy_observation(state[None], None, {COMMAND_KEY: [0.5, 0.1, 0.3]}, previous[:1])
    np.testing.assert_allclose(observation[:, :12], np.tile(state[7:19] - task.home_ctrl, (2, 1)))
    # gravity, trunk frame
    np.testing.assert_allclose(observation[:, 27:30], [[0.0, 0.0, -1.0]] * 2, atol=0.01)
    np.testing.assert_array_equal(observation[:, 30:33], [[0.5, 0.1, 0.3]] * 2)
    # the previous action is not seen (copycat)
    np.testing.assert_array_equal(observation[0], observation[1])


def test_gravity_in_body_is_mujoco_s_rotation_transposed_applied_to_down():
    quats = np.random.default_rng(3).normal(size=(20, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    expected = []
    for quat in quats:
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, quat)
        expected.append(rotation.reshape(3, 3).T @ [0.0, 0.0, -1.0])
    np.testing.assert_allclose(gravity_in_body(quats), expected, atol=1e-12)
    assert gravity_in_body(quats.reshape(4, 5, 4)).shape == (4, 5, 3)  # any leading shape
