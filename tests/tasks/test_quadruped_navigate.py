"""quadruped_navigate: the MPC plans base-velocity commands through the shipped locomotion policy,
which the rollouts and the plant both run (onnxruntime), the shipped policy names its task and
training command, and the robot walks to a goal over it."""

import numpy as np
import pytest

import judo
from judo.core.policies.onnx_policy import OnnxPolicy
from judo.core.rollouts.low_level_rollout import LowLevelRollout
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.quadruped_navigate import COMMAND_RANGE, EVERY, POLICY_PATH, QuadrupedNavigate
from judo.tasks.quadruped_velocity import COMMAND_KEY, QuadrupedVelocity


def test_the_shipped_policy_loads_and_names_its_task_and_training_command():
    policy = OnnxPolicy(POLICY_PATH)
    # joint targets per tick
    assert (policy.observation_size, policy.action_size, policy.horizon) == (35, 12, 1)
    assert policy.metadata["task"] == "quadruped_velocity" and policy.metadata["kind"] == "action"
    assert policy.metadata["name"] == "quadruped_locomotion" and policy.metadata["head"] == "gait"
    assert policy.metadata["training_command"].startswith("python -m judo gait-search ")
    assert POLICY_PATH.stat().st_size < 100_000  # small enough to ship


def test_the_navigate_observation_is_the_velocity_task_s_policy_observation():
    navigate, velocity = QuadrupedNavigate(), QuadrupedVelocity()
    rng = np.random.default_rng(0)
    states = np.concatenate([navigate.model.qpos0, np.zeros(navigate.model.nv)]) + rng.normal(
        0, 0.05, (4, 37)
    )
    command, previous = np.array([0.4, -0.1, 0.3]), navigate.home_ctrl + rng.normal(0, 0.1, (4, 12))
    times = np.array([0.0, 0.1, 0.25, 7.3])
    sensors = np.zeros((4, velocity.model.nsensordata))
    sensors[:, velocity._clock] = times  # the clock sensor reads the sim time
    expected = velocity.policy_observation(states, sensors, {COMMAND_KEY: command}, previous)
    got = navigate.low_level().observe(np.tile(command, (4, 1)), states, previous, times)
    np.testing.assert_allclose(got, expected)
    assert got.shape == (4, 35)
    np.testing.assert_allclose(
        got[:, 33:], np.stack([np.cos(5 * np.pi * times), np.sin(5 * np.pi * times)], 1)
    )


def test_the_observation_written_into_a_tick_s_buffer_is_the_allocated_one_bit_for_bit():
    """The low-level rollouts hand `locomotion_observation` a view of their (N, 35) buffer; what it
    writes there is what it returns without one, for every row and batch size."""
    task = QuadrupedNavigate()
    rng = np.random.default_rng(1)
    for batch in (1, 4, 9):
        states = np.concatenate([task.model.qpos0, np.zeros(task.model.nv)]) + rng.normal(
            0, 0.3, (batch, 37)
        )
        states[:, 3:7] /= np.linalg.norm(states[:, 3:7], axis=1, keepdims=True)
        commands, times = rng.uniform(-0.5, 0.5, (batch, 3)), rng.uniform(0, 100, batch)
        expected = task.locomotion_observation(commands, states, None, times)
        buffer = np.full((batch + 2, 35), np.nan)
        written = task.low_level().observe(commands, states, None, times, out=buffer[1 : batch + 1])
        assert np.shares_memory(written, buffer)
        np.testing.assert_array_equal(buffer[1 : batch + 1], expected)
        assert np.isnan(buffer[[0, -1]]).all()  # the rows of other blocks are untouched


def test_the_task_plans_commands_and_the_plant_runs_the_shipped_policy_on_the_served_one():
    task = QuadrupedNavigate()
    assert (task.nu, task.command_size, task.low_level().every) == (12, 3, EVERY)
    np.testing.assert_array_equal(task.command_range, COMMAND_RANGE)
    with judo.make_controller("quadruped_navigate", "mppi", seed=0, num_workers=1) as controller:
        assert isinstance(controller.backend, LowLevelRollout)
    plant = MujocoSystem.from_task(task, seed=0)
    command = np.array([0.5, 0.0, 0.2])
    state = plant.plant_state()
    plant.apply(command)
    # the first tick: the policy runs on the served command, the state and the plant's time
    plant.step()
    observation = task.locomotion_observation(
        command[None], state[None], np.zeros((1, 12)), np.zeros(1)
    )
    targets = OnnxPolicy(POLICY_PATH).act(observation)[0, 0]  # (12,) held for the tick's 2 steps
    np.testing.assert_allclose(plant.task.data.ctrl, targets, atol=1e-5)
    plant.step()
    np.testing.assert_allclose(plant.task.data.ctrl, targets, atol=1e-5)
    for _ in range(3):  # the next tick, 0.02 s later: the clock moved, so the targets did
        plant.step()
    assert not np.allclose(plant.task.data.ctrl, targets, atol=1e-3)


@pytest.mark.parametrize("seed", [0, 1])
def test_with_its_defaults_it_walks_over_the_policy_to_a_goal_a_metre_away(seed):
    controller = judo.make_controller("quadruped_navigate", "mppi", seed=seed, num_workers=1)
    plant = MujocoSystem.from_task(controller.task, seed=seed)
    task = plant.task
    assert isinstance(task, QuadrupedNavigate) and task.goal_distance() == pytest.approx(
        1.0, abs=0.01
    )
    with controller:
        result = run_episode(controller, plant, duration=3.0, seed=seed)
    assert task.goal_distance() < 0.5 or result.metrics["goals_reached"] >= 1, (
        f"{task.goal_distance():.2f} m left"
    )
    assert result.metrics["falls"] == 0.0
