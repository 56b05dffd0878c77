import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.double_cartpole import POLE_LENGTH, DoubleCartpole, DoubleCartpoleConfig


def rows(
    task: DoubleCartpole, qpos: tuple[float, float, float], qvel=(0.0, 0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """(1, 3, 6) states and (1, 3, nsensordata) sensors holding one pose for three steps."""
    task.data.qpos[:], task.data.qvel[:] = qpos, qvel
    mujoco.mj_forward(task.sim_model, task.data)
    return np.tile([*qpos, *qvel], (1, 3, 1)), np.tile(task.data.sensordata, (1, 3, 1))


def test_model_compiles_with_one_normalised_push_and_traces() -> None:
    task = DoubleCartpole()
    assert (task.model.nq, task.nu) == (3, 1)
    np.testing.assert_array_equal(task.actuator_ctrlrange, [[-1.0, 1.0]])
    names = {task.model.sensor(i).name for i in range(task.model.nsensor)}
    assert {"trace_tip", "trace_elbow"} <= names


def test_tip_error_is_zero_straight_above_the_cart() -> None:
    task = DoubleCartpole()
    states, sensors = rows(task, (1.5, 0.0, 0.0))
    np.testing.assert_allclose(task.tip_error(states, sensors), 0.0, atol=1e-12)
    states, sensors = rows(task, (0.0, np.pi, 0.0))
    np.testing.assert_allclose(task.tip_error(states, sensors), 4 * POLE_LENGTH)


def test_reward_prefers_both_poles_up_over_one_over_none() -> None:
    task = DoubleCartpole()
    cases = [
        rows(task, (0.0, 0.0, 0.0)),  # upright, centred
        rows(task, (0.0, 2 * np.pi, 0.0)),  # upright one turn later: the same
        rows(task, (0.0, np.pi, np.pi)),  # lower pole down, upper pole up
        rows(task, (0.0, np.pi, 0.0)),  # hanging
        rows(task, (2.0, 0.0, 0.0)),  # upright, off centre
        rows(task, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),  # upright, cart moving
        rows(task, (3.5, 0.0, 0.0)),  # upright, past the soft wall 1 m before the end of the rail
    ]
    states = np.concatenate([c[0] for c in cases])
    sensors = np.concatenate([c[1] for c in cases])
    rewards = task.reward(states, sensors, np.zeros((7, 3, 1)), DoubleCartpoleConfig())
    assert rewards.shape == (7,)
    assert rewards[0] == pytest.approx(0.0)
    assert rewards[1] == pytest.approx(0.0, abs=1e-9)
    assert rewards[0] > rewards[2] > rewards[3]
    assert rewards[0] > rewards[4] and rewards[0] > rewards[5]
    assert rewards[4] > rewards[6]
    without_wall = task.reward(
        states[6:], sensors[6:], np.zeros((1, 3, 1)), DoubleCartpoleConfig(w_rail_end=0.0)
    )
    assert without_wall[0] - rewards[6] == pytest.approx(100.0 * 0.5**2 * 3)


def test_balance_cost_ranks_states_near_upright_and_saturates_far_away() -> None:
    task = DoubleCartpole()
    states = np.array(
        [
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],  # upright, centred, at rest
            [0.5, 0.0, 0.0, 0.0, 0.0, 0.0],  # upright, 0.5 m off centre
            [0.0, 0.1, 0.0, 0.0, 0.0, 0.0],  # both poles leaning 0.1 rad
            [0.0, 0.05, 0.0, 0.0, 0.0, 0.0],  # leaning half as far
            [0.0, np.pi, 0.0, 0.0, 0.0, 0.0],  # hanging
            [0.0, 2 * np.pi + 0.1, 0.0, 0.0, 0.0, 0.0],  # leaning 0.1 rad one turn later
        ]
    )
    cost = task.balance_cost(states)
    assert cost[0] == 0.0
    assert 0.0 < cost[1] < 1.0 and 0.0 < cost[2] < 1.0
    assert cost[3] == pytest.approx(cost[2] / 4)  # quadratic near upright
    assert cost[4] == 1.0
    assert cost[5] == pytest.approx(cost[2])


def test_reset_hangs_the_poles_down_at_random() -> None:
    task = DoubleCartpole()
    task.rng = np.random.default_rng(0)
    task.reset()
    first = task.data.qpos.copy()
    task.reset()
    assert not np.allclose(first, task.data.qpos)
    assert abs(abs(task.data.qpos[1]) - np.pi) < 0.21


def test_metrics_measure_the_upright_share_of_the_last_three_seconds() -> None:
    task = DoubleCartpole()
    times = np.arange(1, 501) * 0.01  # 5 s
    states = np.zeros((500, 6))
    states[:, 0] = 0.5
    states[times <= 3.5, 1] = np.pi  # hanging, then upright for the last 1.5 s
    sensors = np.zeros((500, task.model.nsensordata))
    column = task.get_sensor_start_index("trace_tip")
    sensors[:, column] = 0.5
    sensors[:, column + 2] = np.where(times > 3.5, 2 * POLE_LENGTH, -2 * POLE_LENGTH)
    metrics = task.metrics(EpisodeLog(times, states, np.zeros((500, 1)), sensors))
    assert metrics["upright_fraction"] == pytest.approx(0.5, abs=0.01)
    assert metrics["final_tip_error"] == pytest.approx(0.0)
    assert metrics["final_cart_offset"] == pytest.approx(0.5)
    assert metrics["hit_rail_end"] == 0.0


def test_metrics_flag_a_cart_that_reached_the_end_of_its_travel() -> None:
    task = DoubleCartpole()
    travel = task.sim_model.jnt_range[task.sim_model.joint("slider").id, 1]
    times = np.arange(1, 101) * 0.01
    states = np.zeros((100, 6))
    sensors = np.zeros((100, task.model.nsensordata))
    states[50, 0] = -(travel - 0.01)  # one step at the left end, back in the middle at the end
    log = EpisodeLog(times, states, np.zeros((100, 1)), sensors)
    assert task.metrics(log)["hit_rail_end"] == 1.0
    states[50, 0] = -(travel - 0.1)  # near the end but not at it
    assert task.metrics(log)["hit_rail_end"] == 0.0


@pytest.mark.slow
def test_predictive_sampling_swings_both_poles_up_without_reaching_the_rail_end() -> None:
    controller = judo.make_controller("double_cartpole", "ps", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=3.0).log
    controller.close()
    assert plant.task.tip_error(log.states, log.sensors).min() < 0.3
    assert plant.task.metrics(log)["hit_rail_end"] == 0.0
