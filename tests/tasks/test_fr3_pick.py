"""FR3 pick and place: model, gripper, per-phase rewards, phase logic, metrics, and a short closed
loop."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.fr3_pick import ARM_JOINTS, DONE, LIFT, MOVE, PLACE, FR3Pick


def test_model_has_position_servos_over_the_joint_ranges_and_a_unit_gripper() -> None:
    task = FR3Pick()
    assert task.nu == 8 and task.model.nmocap == 1
    for i, name in enumerate(ARM_JOINTS):
        joint = task.model.joint(name)
        assert task.model.actuator_trnid[i, 0] == joint.id
        np.testing.assert_allclose(task.model.actuator_ctrlrange[i], joint.range, atol=1e-12)
    np.testing.assert_array_equal(task.model.actuator_ctrlrange[7], [0.0, 1.0])
    tcp_zaxis = task.data.sensordata[task._zaxis : task._zaxis + 3]
    np.testing.assert_allclose(tcp_zaxis, [0.0, 0.0, -1.0], atol=1e-3)


def test_gripper_control_maps_zero_to_closed_and_one_to_open() -> None:
    task = FR3Pick()
    data = task.data
    for command, opening in ((0.0, 0.0), (0.5, 0.02), (1.0, 0.04)):
        data.ctrl[:7] = data.qpos[task._arm_qpos]
        data.ctrl[7] = command
        for _ in range(150):
            mujoco.mj_step(task.sim_model, data)
        left, right = data.qpos[task._finger_qpos : task._finger_qpos + 2]
        assert left == pytest.approx(opening, abs=2e-3) and right == pytest.approx(
            opening, abs=2e-3
        )


def test_reset_puts_object_and_goal_apart_in_the_workspace_reproducibly() -> None:
    spots = []
    for _ in range(2):
        task = FR3Pick()
        task.rng = np.random.default_rng(5)
        for _ in range(10):
            task.reset()
            obj = task.data.qpos[task._object_qpos : task._object_qpos + 3].copy()
            goal = task.data.mocap_pos[0].copy()
            assert np.linalg.norm(obj[:2] - goal[:2]) >= 0.15
            assert obj[2] == pytest.approx(task.rest_height) and goal[2] == pytest.approx(
                task.rest_height
            )
            assert 0.4 <= obj[0] <= 0.6 and -0.25 <= goal[1] <= 0.25
            spots.append(np.concatenate([obj, goal]))
    np.testing.assert_array_equal(spots[:10], spots[10:])


def phase_sensors(task: FR3Pick, tcp: np.ndarray, obj: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """(nsensordata,) sensors with the gripper pointing down and square to the cube."""
    sensors = np.zeros(task.model.nsensordata)
    sensors[task._tcp : task._tcp + 3] = tcp
    sensors[task._object : task._object + 3] = obj
    sensors[task._goal : task._goal + 3] = goal
    sensors[task._zaxis : task._zaxis + 3] = [0.0, 0.0, -1.0]
    sensors[task._finger_axis : task._finger_axis + 3] = [0.0, 1.0, 0.0]
    sensors[task._object_xaxis : task._object_xaxis + 3] = [1.0, 0.0, 0.0]
    return sensors


def score(task: FR3Pick, cases: list[tuple[np.ndarray, float]], phase: int) -> np.ndarray:
    """Rewards of constant (sensors, gripper opening in m) rollouts of T = 3 steps in `phase`, with
    the gripper commanded to the opening it has."""
    sensors = np.stack([s for s, _ in cases])[:, None, :].repeat(3, axis=1)
    states = np.zeros((len(cases), 3, task.model.nq + task.model.nv))
    openings = np.array([o for _, o in cases])[:, None]
    states[..., task._finger_qpos] = openings
    controls = np.zeros((len(cases), 3, task.nu))
    controls[..., task.model.actuator("gripper").id] = openings / task.max_opening
    return task.reward(states, sensors, controls, task.config, {"phase": phase})


def test_lift_reward_prefers_a_closed_grip_around_the_raised_object() -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, 0.02])
    resting, raised = np.array([0.5, 0.1, 0.02]), np.array([0.5, 0.1, 0.17])
    rewards = score(
        task,
        [
            (phase_sensors(task, raised, raised, goal), 0.0),  # grasped and lifted
            (phase_sensors(task, resting, resting, goal), 0.0),  # grasped on the table
            (phase_sensors(task, resting, resting, goal), 0.04),  # around it, open
            (phase_sensors(task, resting + [0, 0, 0.3], resting, goal), 0.04),  # far above, open
            (phase_sensors(task, resting + [0, 0, 0.3], resting, goal), 0.0),  # far above, closed
        ],
        LIFT,
    )
    assert rewards.shape == (5,) and np.all(rewards <= 0.0)
    assert rewards[0] > rewards[1] > rewards[2]
    assert rewards[2] > rewards[3] > rewards[4]


def test_move_place_and_done_rewards_point_at_the_goal() -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, 0.02])
    carried_near = np.array([0.5, -0.15, 0.17])
    carried_far = np.array([0.5, 0.1, 0.17])
    move = score(
        task,
        [
            (phase_sensors(task, carried_near, carried_near, goal), 0.0),
            (phase_sensors(task, carried_far, carried_far, goal), 0.0),
        ],
        MOVE,
    )
    assert move[0] > move[1]
    place = score(
        task,
        [
            (phase_sensors(task, goal, goal, goal), 0.0),
            (phase_sensors(task, goal + [0, 0, 0.1], goal + [0, 0, 0.1], goal), 0.0),
        ],
        PLACE,
    )
    assert place[0] > place[1]
    above = goal + [0, 0, task.config.lift_height]
    done = score(
        task,
        [
            (phase_sensors(task, above, goal, goal), 0.04),
            (phase_sensors(task, goal, goal, goal), 0.0),
        ],
        DONE,
    )
    assert done[0] > done[1]
    assert done[0] == pytest.approx(0.0, abs=1e-9)


def test_done_reward_charges_joint_targets_pressed_away_from_the_joints() -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, 0.02])
    sensors = np.tile(phase_sensors(task, goal, goal, goal), (2, 3, 1))
    states = np.zeros((2, 3, task.model.nq + task.model.nv))
    states[..., task._finger_qpos] = task.max_opening
    controls = np.zeros((2, 3, task.nu))
    controls[..., task.model.actuator("gripper").id] = 1.0
    # every target 0.1 rad below its joint
    controls[1, :, :7] = states[1, :, task._arm_qpos].T - 0.1
    on_target, pressing = task.reward(states, sensors, controls, task.config, {"phase": DONE})
    assert on_target - pressing == pytest.approx(task.config.w_press * 7 * 0.1)
    before_release = task.reward(states, sensors, controls, task.config, {"phase": PLACE})
    assert before_release[0] == pytest.approx(before_release[1])  # only once the cube is placed


def test_fingers_forced_past_fully_open_score_as_fully_open() -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, 0.02])
    sensors = phase_sensors(task, goal, goal, goal)
    for phase in (LIFT, DONE):
        wide, forced = score(task, [(sensors, 0.04), (sensors, 0.046)], phase)
        assert forced == pytest.approx(wide)


def test_reward_reads_the_phase_from_the_system_metadata() -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, 0.02])
    carried = np.array([0.5, 0.1, 0.17])
    cases = [(phase_sensors(task, carried, carried, goal), 0.0)]
    assert score(task, cases, MOVE)[0] != score(task, cases, LIFT)[0]
    sensors = np.stack([cases[0][0]])[:, None, :]
    states = np.zeros((1, 1, task.model.nq + task.model.nv))
    controls = np.zeros((1, 1, task.nu))
    task.phase = MOVE
    assert task.reward(states, sensors, controls, task.config)[0] == pytest.approx(
        score(task, cases, MOVE)[0]
    )


@pytest.mark.parametrize(
    ("phase", "obj", "held", "expected"),
    [
        (LIFT, [0.5, 0.1, 0.02], False, LIFT),
        (LIFT, [0.5, 0.1, 0.15], True, MOVE),
        (MOVE, [0.5, 0.1, 0.15], True, MOVE),
        (MOVE, [0.5, -0.19, 0.15], True, PLACE),
        (PLACE, [0.5, -0.19, 0.08], True, PLACE),
        (PLACE, [0.5, -0.2, 0.025], True, DONE),
        (PLACE, [0.5, -0.2, 0.025], False, DONE),  # let go right on the goal
        (MOVE, [0.5, 0.1, 0.15], False, MOVE),  # loose in the air: decided once it lands
        (MOVE, [0.5, 0.1, 0.02], True, LIFT),  # on the table far from the goal, even if "held"
        (MOVE, [0.5, -0.2, 0.02], False, LIFT),  # dropped next to the goal
        (PLACE, [0.5, -0.18, 0.02], False, LIFT),  # dropped short of the goal while lowered
        (DONE, [0.5, -0.2, 0.02], False, DONE),
        (DONE, [0.5, -0.1, 0.02], False, LIFT),
    ],
)
def test_phase_follows_the_object_and_the_grasp(
    phase: int, obj: list[float], held: bool, expected: int
) -> None:
    task = FR3Pick()
    goal = np.array([0.5, -0.2, task.rest_height])
    assert task.next_phase(phase, np.array(obj), goal, 0.15, held) == expected


def test_object_counts_as_held_only_between_fingers_it_holds_apart() -> None:
    task = FR3Pick()
    obj = np.array([0.5, 0.1, 0.17])
    assert task.holds_object(obj + [0.0, 0.0, 0.01], obj, 0.02)
    # fingers shut: nothing between them
    assert not task.holds_object(obj + [0.0, 0.0, 0.01], obj, 0.005)
    assert not task.holds_object(obj + [0.0, 0.05, 0.0], obj, 0.02)  # beside the object


def put_object_in_the_gripper(task: FR3Pick, opening: float) -> None:
    """Move the plant's cube to its gripper centre with the fingers `opening` (m) apart, sensors
    updated."""
    mujoco.mj_forward(task.sim_model, task.data)
    tcp = task.data.sensordata[task._tcp : task._tcp + 3].copy()
    task.data.qpos[task._object_qpos : task._object_qpos + 3] = tcp
    task.data.qpos[task._finger_qpos : task._finger_qpos + 2] = opening
    mujoco.mj_forward(task.sim_model, task.data)


def test_plant_goes_back_to_lift_when_the_object_lies_loose_on_the_table() -> None:
    task = FR3Pick()
    put_object_in_the_gripper(task, 0.02)
    held_at = task.data.qpos[task._object_qpos : task._object_qpos + 2]
    # the goal well away: the random one may lie under the gripper
    task.data.mocap_pos[0, :2] = held_at + [0.0, 0.2]
    task.phase = MOVE
    task.pre_sim_step()
    assert task.phase == MOVE  # carried
    goal = task.data.mocap_pos[0]
    # near: the old rule missed it
    short_of_goal = [goal[0] + 2.0 * task.place_radius, goal[1], task.rest_height]
    task.data.qpos[task._object_qpos : task._object_qpos + 3] = short_of_goal
    task.data.qpos[task._finger_qpos : task._finger_qpos + 2] = 0.003  # fingers closed on nothing
    mujoco.mj_forward(task.sim_model, task.data)
    task.phase = PLACE
    task.pre_sim_step()
    assert task.phase == LIFT and task.get_sim_metadata() == {"phase": LIFT}


def test_plant_advances_its_phase_and_publishes_it() -> None:
    task = FR3Pick()
    task.data.qpos[task._object_qpos + 2] = task.rest_height + 0.15
    task.data.time = 1.5
    task.pre_sim_step()
    assert task.phase == MOVE and task.get_sim_metadata() == {"phase": MOVE}
    task.data.qpos[task._object_qpos : task._object_qpos + 3] = task.data.mocap_pos[0]
    task.phase = PLACE
    task.pre_sim_step()
    assert task.phase == DONE and task.max_phase == DONE and task.time_placed == 1.5
    task.reset()
    assert task.phase == LIFT and task.max_phase == LIFT and np.isnan(task.time_placed)


def test_metrics_judge_the_final_distance_to_the_goal() -> None:
    task = FR3Pick()
    sensors = np.zeros((2, task.model.nsensordata))
    sensors[-1, task._goal : task._goal + 3] = [0.5, -0.2, 0.02]
    sensors[-1, task._object : task._object + 3] = [0.5, -0.18, 0.02]
    log = EpisodeLog(np.array([0.01, 0.02]), np.zeros((2, 1)), np.zeros((2, 8)), sensors)
    task.max_phase, task.time_placed = DONE, 4.2
    metrics = task.metrics(log)
    assert metrics == {
        "success": 1.0,
        "final_distance": pytest.approx(0.02),
        "phase_reached": 3.0,
        "time_to_place": 4.2,
    }
    sensors[-1, task._object] = 0.45
    task.time_placed = float("nan")
    assert task.metrics(log)["success"] == 0.0
    assert task.metrics(log)["time_to_place"] == 0.02  # never placed: the episode's length


def test_warm_start_holds_the_arm_with_the_gripper_open() -> None:
    task = FR3Pick()
    task.reset()
    state = np.concatenate([task.data.qpos, task.data.qvel])
    np.testing.assert_array_equal(
        task.optimizer_warm_start(state), np.append(task.data.qpos[task._arm_qpos], 1.0)
    )


@pytest.mark.slow
def test_fr3_pick_cem_grasps_and_lifts_the_cube() -> None:
    ctrl = judo.make_controller("fr3_pick", "cem", seed=1)
    # seed 1 reaches the cube in about 3.4 s and lifts it by 6 s
    plant = MujocoSystem.from_task(ctrl.task, seed=1)
    result = run_episode(ctrl, plant, 8.0, seed=1)
    ctrl.close()
    tcp, obj = (
        result.log.sensors[:, plant.task._tcp : plant.task._tcp + 3],
        result.log.sensors[:, plant.task._object : plant.task._object + 3],
    )
    gaps = np.linalg.norm(tcp - obj, axis=-1)
    assert gaps.min() < 0.02 < gaps[0]
    assert result.metrics["phase_reached"] >= MOVE, (
        f"closest approach {gaps.min():.3f} m, phase {plant.task.max_phase}"
    )
