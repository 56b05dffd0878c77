"""quadruped_navigate: the MPC plans base-velocity commands through the shipped locomotion policy, which the rollouts
and the plant both run (onnxruntime), and the shipped policy names its task and training command."""

import numpy as np

import judo
from judo.core.low_level import LowLevelRollout
from judo.core.onnx_policy import OnnxPolicy
from judo.runtime.system import MujocoSystem
from judo.tasks.quadruped_navigate import COMMAND_RANGE, EVERY, POLICY_PATH, QuadrupedNavigate
from judo.tasks.quadruped_velocity import COMMAND_KEY, QuadrupedVelocity


def test_the_shipped_policy_loads_and_names_its_task_and_training_command():
    policy = OnnxPolicy(POLICY_PATH)
    assert (policy.observation_size, policy.action_size, policy.horizon) == (33, 12, 4)  # a chunk: 4 knots
    assert policy.metadata["task"] == "quadruped_velocity" and policy.metadata["kind"] == "chunk"
    assert policy.metadata["name"] == "quadruped_locomotion"
    assert "python -m judo distill" in policy.metadata["training_command"]
    assert POLICY_PATH.stat().st_size < 2_000_000  # small enough to ship


def test_the_navigate_observation_is_the_velocity_task_s_policy_observation():
    navigate, velocity = QuadrupedNavigate(), QuadrupedVelocity()
    rng = np.random.default_rng(0)
    states = np.concatenate([navigate.model.qpos0, np.zeros(navigate.model.nv)]) + rng.normal(0, 0.05, (4, 37))
    command, previous = np.array([0.4, -0.1, 0.3]), navigate.home_ctrl + rng.normal(0, 0.1, (4, 12))
    expected = velocity.policy_observation(states, None, {COMMAND_KEY: command}, previous)
    got = navigate.low_level().observe(np.tile(command, (4, 1)), states, previous)
    np.testing.assert_allclose(got, expected)


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
    plant.step()  # the first tick: the policy runs on the served command and the state; its chunk's first knot
    observation = task.locomotion_observation(command[None], state[None], np.zeros((1, 12)))
    knots = OnnxPolicy(POLICY_PATH).act(observation)[0]  # (4, 12) over 0.5 s
    np.testing.assert_allclose(plant.task.data.ctrl, knots[0], atol=1e-5)
    plant.step()  # the tick's second step: 0.01 s along the chunk's cubic
    expected = task.low_level().step_weights(EVERY, task.dt)[1] @ knots
    np.testing.assert_allclose(plant.task.data.ctrl, expected, atol=1e-5)
