"""LEAP cube tasks: models, reward, goal resampling, drop reset, metrics, and a short closed
loop."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.leap_cube import (
    HAND_JOINTS,
    PLANT_MODEL_PATH,
    LeapCube,
    LeapCubeDown,
    LeapCubeDownConfig,
    quat_angle,
)


def sensors_at(task: LeapCube, qpos: np.ndarray, goal_quat: np.ndarray) -> np.ndarray:
    """(nsensordata,) the planning model's sensors with the given qpos and goal orientation."""
    data = mujoco.MjData(task.model)
    data.qpos[:] = qpos
    data.mocap_quat[0] = goal_quat
    mujoco.mj_forward(task.model, data)
    return data.sensordata.copy()


def turned(quat: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    turn = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, turn, quat)
    return out


@pytest.mark.parametrize("task_cls", [LeapCube, LeapCubeDown])
def test_models_compile_with_position_actuators_over_the_joint_ranges(
    task_cls: type[LeapCube],
) -> None:
    task = task_cls()
    assert task.nu == 16 and task.model.nmocap == 1
    for i, name in enumerate(HAND_JOINTS):
        joint = task.model.joint(name)
        assert task.model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
        assert task.model.actuator_trnid[i, 0] == joint.id
        np.testing.assert_allclose(task.model.actuator_ctrlrange[i], joint.range, atol=1e-12)
    for sensor in ("cube_pos", "cube_quat", "goal_quat", "trace_cube", "hand/trace_thumb_tip"):
        task.get_sensor_start_index(sensor)
    goal_geoms = task.model.geom_bodyid == task.model.body("goal").id
    assert (
        not task.model.geom_contype[goal_geoms].any()
        and not task.model.geom_conaffinity[goal_geoms].any()
    )


def test_plant_model_differs_from_the_planning_model_in_friction_only() -> None:
    task = LeapCube(sim_model_path=PLANT_MODEL_PATH)
    assert task.sim_model is not task.model
    assert task.sim_model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE
    assert not task.model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE
    assert task.sim_model.opt.o_friction[0] != task.model.geom("cube").friction[0]
    np.testing.assert_array_equal(task.sim_model.key_qpos, task.model.key_qpos)


def test_plant_model_loads_from_a_relative_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(PLANT_MODEL_PATH.parent.parent)
    task = LeapCube(sim_model_path="models/leap_cube_plant.xml")
    assert task.sim_model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE


def test_reward_prefers_the_goal_orientation_and_the_resting_spot() -> None:
    task = LeapCube()
    home = task.model.key_qpos[0].copy()
    cube_quat = home[task._cube_qpos + 3 : task._cube_qpos + 7]
    at_goal = sensors_at(task, home, cube_quat)
    turned_away = sensors_at(task, home, turned(cube_quat, task._palm_axes[:, 2], np.pi / 2))
    shifted = home.copy()
    shifted[task._cube_qpos] += 0.03
    displaced = sensors_at(task, shifted, cube_quat)
    # (3, T=5, nsensordata)
    sensors = np.stack([at_goal, turned_away, displaced])[:, None, :].repeat(5, axis=1)
    states = np.zeros((3, 5, task.model.nq + task.model.nv))
    controls = np.tile(task.model.key_ctrl[0], (3, 5, 1))
    rewards = task.reward(states, sensors, controls, task.config)
    assert rewards.shape == (3,)
    assert np.all(rewards <= 0.0)
    assert rewards[0] > rewards[1] and rewards[0] > rewards[2]
    expected_turn_cost = task.config.w_orientation * (np.pi / 2) ** 2
    assert rewards[0] - rewards[1] == pytest.approx(expected_turn_cost, rel=1e-6)


def test_palm_down_reward_adds_the_slip_and_cube_speed_costs_to_the_palm_up_terms() -> None:
    task = LeapCubeDown()
    assert isinstance(task.config, LeapCubeDownConfig)
    home = task.model.key_qpos[0].copy()
    slipped = home.copy()
    # 2 cm towards the wrist
    slipped[task._cube_qpos : task._cube_qpos + 3] -= 0.02 * task._palm_axes[:, 0]
    sensors = np.stack(
        [sensors_at(task, q, task.data.mocap_quat[0]) for q in (home, slipped, home)]
    )
    sensors = sensors[:, None, :].repeat(5, axis=1)  # (3, T=5, nsensordata)
    states = np.zeros((3, 5, task.model.nq + task.model.nv))
    states[2, :, task._cube_vel : task._cube_vel + 3] = [0.1, 0.0, 0.0]
    controls = np.tile(task.model.key_ctrl[0], (3, 5, 1))
    config = task.config
    rewards = task.reward(states, sensors, controls, config)
    palm_up_terms = LeapCube.reward(task, states, sensors, controls, config)
    # palm-frame x, y
    offsets = sensors[:, 0, task._cube_pos : task._cube_pos + 2] - task.rest_position[:2]
    assert offsets[1, 0] == pytest.approx(offsets[0, 0] - 0.02)
    slip_cost = config.w_slip * np.square(offsets).sum(-1)
    assert palm_up_terms[1] - rewards[1] == pytest.approx(slip_cost[1])
    assert palm_up_terms[2] - rewards[2] == pytest.approx(
        slip_cost[2] + config.w_cube_velocity * 0.1**2
    )
    assert palm_up_terms[0] - rewards[0] == pytest.approx(slip_cost[0])


def test_quat_angle_ignores_the_quaternion_sign() -> None:
    q = turned(np.array([1.0, 0, 0, 0]), np.array([0.0, 0, 1]), 0.3)
    assert quat_angle(q, -q) == pytest.approx(0.0, abs=1e-6)
    assert quat_angle(q, np.array([1.0, 0, 0, 0])) == pytest.approx(0.3)


def test_reached_goal_is_counted_and_replaced_by_a_90_degree_turn_about_a_palm_axis() -> None:
    task = LeapCube()
    task.rng = np.random.default_rng(0)
    task.reset()
    old_goal = task.data.mocap_quat[0].copy()
    assert task.cube_goal_angle() == pytest.approx(np.pi / 2)
    task.pre_sim_step()
    assert task.goals_reached == 0
    task.data.qpos[task._cube_qpos + 3 : task._cube_qpos + 7] = turned(
        old_goal, task._palm_axes[:, 0], 0.3
    )
    task.pre_sim_step()
    assert task.goals_reached == 1
    new_goal = task.data.mocap_quat[0]
    assert quat_angle(new_goal, old_goal) == pytest.approx(np.pi / 2)
    relative = np.zeros(4)
    mujoco.mju_mulQuat(relative, new_goal, old_goal * [1, -1, -1, -1])
    axis = relative[1:] / np.linalg.norm(relative[1:])
    assert np.max(np.abs(task._palm_axes.T @ axis)) == pytest.approx(1.0)


def test_goal_sequence_is_reproducible_from_the_seed() -> None:
    goals = []
    for _ in range(2):
        task = LeapCube()
        task.rng = np.random.default_rng(7)
        task.reset()
        goals.append([task.next_goal(task.data.mocap_quat[0]) for _ in range(5)])
    np.testing.assert_array_equal(goals[0], goals[1])


@pytest.mark.parametrize("task_cls", [LeapCube, LeapCubeDown])
def test_dropped_cube_is_counted_and_reset_to_home(task_cls: type[LeapCube]) -> None:
    task = task_cls()
    goal = task.data.mocap_quat[0].copy()
    task.data.qpos[task._cube_qpos + 2] = task.drop_height - 0.01
    task.data.qvel[:] = 1.0
    task.post_sim_step()
    assert task.drops == 1
    np.testing.assert_array_equal(task.data.qpos, task.sim_model.key_qpos[0])
    assert not task.data.qvel.any()
    np.testing.assert_array_equal(task.data.mocap_quat[0], goal)
    task.post_sim_step()
    assert task.drops == 1


def test_metrics_report_goals_per_minute_and_drops() -> None:
    task = LeapCube()
    task.goals_reached, task.drops = 7, 1
    steps = round(30.0 / task.dt)
    log = EpisodeLog(
        np.arange(1, steps + 1) * task.dt,
        np.zeros((steps, 1)),
        np.zeros((steps, 16)),
        np.zeros((steps, 1)),
    )
    assert task.metrics(log) == {
        "goals_reached": 7.0,
        "goals_per_minute": pytest.approx(14.0),
        "drops": 1.0,
    }
    task.reset()
    assert task.metrics(log)["goals_reached"] == 0.0


def test_warm_start_holds_the_current_joints_palm_up_and_squeezes_palm_down() -> None:
    up, down = LeapCube(), LeapCubeDown()
    state = np.concatenate([up.data.qpos, up.data.qvel])
    np.testing.assert_array_equal(up.optimizer_warm_start(state), up.data.qpos[up._hand_qpos])
    state = np.concatenate([down.data.qpos, down.data.qvel])
    squeeze = down.optimizer_warm_start(state) - down.data.qpos[down._hand_qpos]
    np.testing.assert_allclose(
        squeeze, down.model.key_ctrl[0] - down.model.key_qpos[0][down._hand_qpos]
    )
    assert squeeze.max() > 0.05


def test_planner_rollouts_see_the_plants_goal() -> None:
    ctrl = judo.make_controller("leap_cube", "cem", seed=0)
    seen = []
    reward = ctrl.task.reward
    ctrl.task.reward = lambda states, sensors, *args: (
        seen.append(sensors.copy()) or reward(states, sensors, *args)
    )
    plant = LeapCube()
    plant.rng = np.random.default_rng(3)
    plant.reset()
    state = MujocoSystem(plant).read_state()
    ctrl.update_action(state.state, state.time, state.metadata)
    ctrl.close()
    goal = ctrl.task.get_sensor_start_index("goal_quat")
    assert not np.allclose(plant.data.mocap_quat[0], ctrl.task.model.body("goal").quat)
    np.testing.assert_allclose(
        seen[0][..., goal : goal + 4], np.broadcast_to(plant.data.mocap_quat[0], (32, 50, 4))
    )


def closed_loop_angles(
    task_name: str, seconds: float, seed: int
) -> tuple[MujocoSystem, np.ndarray]:
    """Default CEM on `task_name` for `seconds` (no latency); the plant and its (S,) cube-goal
    angles."""
    ctrl = judo.make_controller(task_name, "cem", seed=seed)
    plant = MujocoSystem.from_task(ctrl.task, seed)
    result = run_episode(ctrl, plant, seconds, seed=seed)
    ctrl.close()
    cube, goal = (
        ctrl.task.get_sensor_start_index("cube_quat"),
        ctrl.task.get_sensor_start_index("goal_quat"),
    )
    return plant, quat_angle(
        result.log.sensors[:, cube : cube + 4], result.log.sensors[:, goal : goal + 4]
    )


@pytest.mark.slow
def test_leap_cube_cem_turns_the_cube_towards_its_goal() -> None:
    plant, angles = closed_loop_angles("leap_cube", 4.0, seed=0)
    assert plant.task.drops == 0
    assert plant.task.goals_reached >= 1 or angles.min() < angles[0] - 0.4, angles[::20]


@pytest.mark.slow
def test_leap_cube_down_cem_holds_the_cube_and_turns_it() -> None:
    plant, angles = closed_loop_angles("leap_cube_down", 4.0, seed=0)
    assert plant.task.drops == 0
    assert plant.task.goals_reached >= 1 or angles.min() < angles[0] - 0.3, angles[::20]
