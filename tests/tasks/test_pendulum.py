import numpy as np
import pytest

import judo
from judo.core.norms import wrap_angle
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.pendulum import Pendulum, PendulumConfig


def test_model_compiles_with_a_normalised_torque_and_a_tip_trace() -> None:
    task = Pendulum()
    assert (task.model.nq, task.model.nv, task.nu) == (1, 1, 1)
    np.testing.assert_array_equal(task.actuator_ctrlrange, [[-1.0, 1.0]])
    assert task.get_sensor_start_index("trace_tip") == 0
    assert "pendulum" in judo.get_registered_tasks()


def test_reset_hangs_the_pole_down_at_random() -> None:
    task = Pendulum()
    starts = []
    for seed in range(3):
        task.rng = np.random.default_rng(seed)
        task.reset()
        starts.append(task.data.qpos[0])
    assert all(abs(wrap_angle(np.array(a))) > np.pi - 0.31 for a in starts)
    assert len(set(starts)) == 3


def test_reward_prefers_upright_still_and_gentle() -> None:
    task = Pendulum()
    config = PendulumConfig()
    states = np.zeros((4, 5, 2))
    states[1, :, 0] = np.pi  # hanging
    states[2, :, 1] = 3.0  # upright but spinning
    states[3, :, 0] = 2 * np.pi  # upright, one turn later: same as upright
    controls = np.zeros((4, 5, 1))
    rewards = task.reward(states, np.zeros((4, 5, 3)), controls, config)
    assert rewards.shape == (4,)
    assert rewards[0] == pytest.approx(0.0)
    assert rewards[3] == pytest.approx(0.0, abs=1e-9)
    assert rewards[0] > rewards[2] > rewards[1]
    pushed = task.reward(states[:1], np.zeros((1, 5, 3)), np.ones((1, 5, 1)), config)
    assert pushed[0] < rewards[0]


def test_metrics_measure_the_upright_share_of_the_last_three_seconds() -> None:
    task = Pendulum()
    times = np.arange(1, 601) * 0.01  # 6 s
    # upright (one turn on) for the last 1.5 s
    angles = np.where(times > 4.5, 2 * np.pi + 0.1, np.pi)
    log = EpisodeLog(
        times, np.stack([angles, np.zeros(600)], axis=1), np.zeros((600, 1)), np.zeros((600, 3))
    )
    metrics = task.metrics(log)
    assert metrics["upright_fraction"] == pytest.approx(0.5, abs=0.01)
    assert metrics["final_angle_error"] == pytest.approx(0.1)


def test_predictive_sampling_swings_the_pole_up_and_holds_it() -> None:
    controller = judo.make_controller("pendulum", "ps", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=7.0).log
    controller.close()
    assert plant.task.metrics(log)["upright_fraction"] > 0.5
