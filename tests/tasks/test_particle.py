import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.particle import GOAL_SPAN, Particle, ParticleConfig


def sensors_for(particle: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """(..., 6) sensor rows [trace_particle xyz, goal_position xyz] for (..., 2) positions."""
    height = np.full(particle.shape[:-1] + (1,), 0.02)
    return np.concatenate([particle, height, goal, height], axis=-1)


def test_model_compiles_with_normalised_forces_a_trace_and_a_mocap_goal() -> None:
    task = Particle()
    assert (task.model.nq, task.nu, task.model.nmocap) == (2, 2, 1)
    np.testing.assert_array_equal(task.actuator_ctrlrange, [[-1.0, 1.0], [-1.0, 1.0]])
    assert task.get_sensor_start_index("trace_particle") == 0
    assert task.get_sensor_start_index("goal_position") == 3


def test_reset_draws_particle_and_goal_inside_the_walls() -> None:
    task = Particle()
    task.rng = np.random.default_rng(3)
    task.reset()
    first = (task.data.qpos.copy(), task.data.mocap_pos[0].copy())
    task.reset()
    assert not np.allclose(first[1], task.data.mocap_pos[0])
    assert np.all(np.abs(task.data.qpos) <= GOAL_SPAN) and np.all(
        np.abs(task.data.mocap_pos[0, :2]) <= GOAL_SPAN
    )
    np.testing.assert_array_equal(task.data.qvel, 0.0)


def test_reward_prefers_the_particle_on_the_goal_slow_and_gentle() -> None:
    task = Particle()
    config = ParticleConfig()
    goal = np.array([0.2, -0.1])
    particle = np.array([[0.2, -0.1], [0.2, -0.1], [0.0, 0.0], [-0.3, 0.3]])[:, None, :].repeat(
        3, axis=1
    )
    states = np.zeros((4, 3, 4))
    states[1, :, 2] = 1.0  # on the goal but moving
    rewards = task.reward(
        states,
        sensors_for(particle, np.broadcast_to(goal, particle.shape)),
        np.zeros((4, 3, 2)),
        config,
    )
    assert rewards.shape == (4,)
    assert rewards[0] == pytest.approx(0.0)
    assert rewards[0] > rewards[1] and rewards[0] > rewards[2] > rewards[3]


def test_a_reached_goal_moves_on_and_metrics_count_the_moves() -> None:
    task = Particle()
    task.rng = np.random.default_rng(0)
    task.reset()
    task.data.qpos[:2] = task.data.mocap_pos[0, :2] + 0.01
    old_goal = task.data.mocap_pos[0].copy()
    task.pre_sim_step()
    assert not np.allclose(task.data.mocap_pos[0], old_goal)
    task.config.new_goal_on_reach = False
    task.data.qpos[:2] = task.data.mocap_pos[0, :2]
    held = task.data.mocap_pos[0].copy()
    task.pre_sim_step()
    np.testing.assert_array_equal(task.data.mocap_pos[0], held)

    times = np.arange(1, 3001) * 0.01  # 30 s with goals moving at steps 1000 and 2000
    goal = np.zeros((3000, 2))
    goal[1000:2000], goal[2000:] = [0.1, 0.1], [-0.2, 0.3]
    particle = goal + [0.0, 0.05]
    log = EpisodeLog(times, np.zeros((3000, 4)), np.zeros((3000, 2)), sensors_for(particle, goal))
    metrics = task.metrics(log)
    assert metrics["goals_reached"] == 2.0
    assert metrics["goals_per_minute"] == pytest.approx(4.0)
    assert metrics["final_distance"] == pytest.approx(0.05)


def test_predictive_sampling_reaches_several_goals() -> None:
    controller = judo.make_controller("particle", "ps", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=8.0).log
    controller.close()
    assert plant.task.metrics(log)["goals_reached"] >= 3
