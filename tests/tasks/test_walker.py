import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.walker import Walker, WalkerConfig


def sensors_of(task: Walker, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
    """(nsensordata,) sensor row of the walker in the given pose and motion."""
    task.data.qpos[:], task.data.qvel[:] = qpos, qvel
    mujoco.mj_forward(task.sim_model, task.data)
    return task.data.sensordata.copy()


def test_model_compiles_with_six_normalised_torques_and_traces() -> None:
    task = Walker()
    assert (task.model.nq, task.model.nv, task.nu) == (9, 9, 6)
    np.testing.assert_array_equal(task.actuator_ctrlrange, np.tile([-1.0, 1.0], (6, 1)))
    names = {task.model.sensor(i).name for i in range(task.model.nsensor)}
    assert {"trace_head", "trace_right_foot", "trace_left_foot"} <= names


def test_reward_prefers_running_upright_at_the_target_speed() -> None:
    task = Walker()
    config = WalkerConfig()
    standing = np.zeros(9)
    leaning = standing.copy()
    leaning[2] = 0.8  # torso pitched forward
    fallen = standing.copy()
    fallen[1] = -1.0  # torso a metre lower
    running = np.zeros(9)
    running[0] = config.target_speed
    rows = [
        sensors_of(task, standing, running),
        sensors_of(task, standing, np.zeros(9)),
        sensors_of(task, leaning, running),
        sensors_of(task, fallen, running),
    ]
    sensors = np.array(rows)[:, None, :].repeat(3, axis=1)
    rewards = task.reward(np.zeros((4, 3, 18)), sensors, np.zeros((4, 3, 6)), config)
    assert rewards.shape == (4,)
    assert rewards[0] == pytest.approx(0.0, abs=1e-6)
    assert rewards[0] > rewards[1] and rewards[0] > rewards[2] > rewards[3]


def test_reset_stands_the_walker_with_random_jitter() -> None:
    task = Walker()
    task.rng = np.random.default_rng(0)
    task.reset()
    first = task.data.qpos.copy()
    task.reset()
    assert not np.allclose(first, task.data.qpos)
    assert task.data.sensordata[task.get_sensor_start_index("trace_head") + 2] > 1.6


def test_metrics_report_speed_falls_and_head_height() -> None:
    task = Walker()
    times = np.arange(1, 201) * 0.01  # 2 s
    states = np.zeros((200, 18))
    states[:, 0] = np.linspace(0.01, 2.0, 200)  # 1 m/s
    sensors = np.zeros((200, task.model.nsensordata))
    sensors[:, task.get_sensor_start_index("trace_head") + 2] = np.where(times > 1.5, 0.5, 1.6)
    metrics = task.metrics(EpisodeLog(times, states, np.zeros((200, 6)), sensors))
    assert metrics["mean_forward_speed"] == pytest.approx(1.0, abs=0.01)
    assert metrics["fallen_fraction"] == pytest.approx(0.25)
    assert metrics["final_head_height"] == pytest.approx(0.5)


@pytest.mark.slow
def test_mppi_makes_the_walker_run_forward_without_falling() -> None:
    controller = judo.make_controller("walker", "mppi", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=4.0).log
    controller.close()
    metrics = plant.task.metrics(log)
    assert metrics["mean_forward_speed"] > 0.7
    assert metrics["fallen_fraction"] == 0.0
