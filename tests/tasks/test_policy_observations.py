"""The built-in tasks' own policy observations: particle and push_t see their goal (relative to what
must reach it), pendulum, acrobot and cartpole see cos and sin of their unlimited hinges; batched,
and as long as `policy_observation_size()` says."""

import numpy as np
import pytest

from judo.core.configuration.registry import lookup_task
from judo.core.model import model_mocap_poses
from judo.core.policies.policy_controller import make_policy_controller
from judo.core.policy import Policy

SIZES = {"particle": 6, "push_t": 13, "pendulum": 3, "acrobot": 6, "cartpole": 5, "cartpole_pd": 5}


def make(name: str):
    return lookup_task(name)[0]()


def yaw_quat(yaw: float) -> np.ndarray:
    """(1, 4) [w, x, y, z] of a turn by `yaw` about the vertical."""
    return np.array([[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]])


@pytest.mark.parametrize("name", sorted(SIZES))
def test_the_observation_is_batched_row_by_row_and_its_size_is_the_one_reported(name):
    task = make(name)
    states = np.random.default_rng(1).uniform(-1.0, 1.0, (5, task.model.nq + task.model.nv))
    observation = task.policy_observation(states)
    assert observation.shape == (5, SIZES[name]) == (5, task.policy_observation_size())
    assert np.all(np.isfinite(observation))
    np.testing.assert_array_equal(observation[3:4], task.policy_observation(states[3:4]))


def test_particle_sees_the_goal_relative_to_itself():
    task = make("particle")
    states = np.array([[0.1, -0.2, 0.3, 0.4], [0.0, 0.0, 0.0, 0.0]])
    goal = {"mocap_pos": np.array([[0.3, 0.1, 0.0]])}
    observation = task.policy_observation(states, None, goal)
    np.testing.assert_array_equal(observation[:, :4], states)
    np.testing.assert_allclose(observation[:, 4:], [[0.2, 0.3], [0.3, 0.1]], atol=1e-15)
    moved = task.policy_observation(states, None, {"mocap_pos": np.array([[-0.3, 0.1, 0.0]])})
    np.testing.assert_allclose(moved[:, 4:] - observation[:, 4:], [[-0.6, 0.0]] * 2, atol=1e-15)
    own = model_mocap_poses(task.model)["mocap_pos"][0, :2]
    # no metadata
    np.testing.assert_allclose(task.policy_observation(states)[:, 4:], own - states[:, :2])
    per_row = {"mocap_pos": np.array([[[0.3, 0.1, 0.0]], [[-0.3, 0.1, 0.0]]])}  # (B, nmocap, 3)
    np.testing.assert_allclose(
        task.policy_observation(states, None, per_row)[:, 4:], [[0.2, 0.3], [-0.3, 0.1]]
    )


def test_push_t_sees_the_goal_and_heading_error_relative_to_the_block():
    task = make("push_t")
    states = np.zeros((1, 10))
    states[0, :5] = [0.1, 0.2, 0.5, 0.3, -0.1]  # block x, y, heading, pusher x, y
    states[0, 5:] = [1.0, 2.0, 3.0, 4.0, 5.0]
    goal = {"mocap_pos": np.array([[0.4, 0.0, 0.001]]), "mocap_quat": yaw_quat(0.2)}
    (row,) = task.policy_observation(states, None, goal)
    np.testing.assert_allclose(row[0:2], [0.3, -0.2], atol=1e-15)
    np.testing.assert_allclose(row[2:4], [np.cos(0.3), np.sin(0.3)], atol=1e-12)
    np.testing.assert_allclose(row[4:6], [0.2, -0.3], atol=1e-15)
    np.testing.assert_allclose(row[6:8], [np.cos(0.5), np.sin(0.5)], atol=1e-15)
    np.testing.assert_array_equal(row[8:], [1.0, 2.0, 3.0, 4.0, 5.0])
    turned = task.policy_observation(states, None, {**goal, "mocap_quat": yaw_quat(-0.4)})
    np.testing.assert_allclose(turned[0, 2:4], [np.cos(0.9), np.sin(0.9)], atol=1e-12)
    np.testing.assert_array_equal(np.delete(turned[0], [2, 3]), np.delete(row, [2, 3]))
    spun = states.copy()
    spun[0, 2] += 4 * np.pi  # the same pose after two full turns
    np.testing.assert_allclose(task.policy_observation(spun, None, goal), [row], atol=1e-12)


def test_push_t_of_a_recorded_step_needs_only_its_mocap_pos():
    """A collect file keeps obs/mocap_pos only; the goal's heading is the model's in every
    episode."""
    task = make("push_t")
    states = np.random.default_rng(2).uniform(-0.3, 0.3, (4, 10))
    own = model_mocap_poses(task.model)
    recorded = {"mocap_pos": own["mocap_pos"] + [0.1, -0.1, 0.0]}
    np.testing.assert_array_equal(
        task.policy_observation(states, None, recorded),
        task.policy_observation(states, None, {**recorded, "mocap_quat": own["mocap_quat"]}),
    )


@pytest.mark.parametrize(("name", "angles"), [("pendulum", [0]), ("acrobot", [0, 1])])
def test_hinge_angles_a_full_turn_apart_give_the_same_observation(name, angles):
    task = make(name)
    states = np.random.default_rng(3).uniform(-3.0, 3.0, (6, task.model.nq + task.model.nv))
    turned = states.copy()
    turned[:, angles] += 2 * np.pi * np.array([1.0, -3.0])[: len(angles)]
    observation = task.policy_observation(states)
    np.testing.assert_allclose(task.policy_observation(turned), observation, atol=1e-12)
    nq = task.model.nq
    np.testing.assert_allclose(
        observation[:, : 2 * nq], np.hstack([np.cos(states[:, :nq]), np.sin(states[:, :nq])])
    )
    np.testing.assert_array_equal(observation[:, 2 * nq :], states[:, nq:])  # the rates as they are


@pytest.mark.parametrize("name", ["cartpole", "cartpole_pd"])
def test_cartpole_sees_the_cart_cos_and_sin_of_the_pole_and_the_velocities(name):
    task = make(name)
    states = np.array(
        [
            [0.3, 0.0, -0.5, 1.5],  # upright
            [0.3, 2 * np.pi, -0.5, 1.5],  # upright after a full turn
            [-0.2, -4 * np.pi, 0.0, 0.0],  # upright after two turns back
            [0.1, np.pi, 0.2, -0.7],  # hanging down
            [0.0, np.pi / 2, 1.0, 2.0],  # a quarter turn
        ]
    )
    observation = task.policy_observation(states)
    expected = [
        [0.3, 1.0, 0.0, -0.5, 1.5],
        [0.3, 1.0, 0.0, -0.5, 1.5],
        [-0.2, 1.0, 0.0, 0.0, 0.0],
        [0.1, -1.0, 0.0, 0.2, -0.7],
        [0.0, 0.0, 1.0, 1.0, 2.0],
    ]
    np.testing.assert_allclose(observation, expected, atol=1e-12)
    # 0 and 2 pi: one pose, one observation
    np.testing.assert_allclose(observation[1], observation[0], atol=1e-12)
    small = task.policy_observation(np.array([[0.0, 0.01, 0.0, 0.0]]))
    # sin angle reads as the angle near upright
    np.testing.assert_allclose(small[0, 2], 0.01, rtol=1e-4)


class Recording(Policy):
    """A per-step policy for particle that keeps what it saw and pushes nowhere."""

    observation_size, action_size = 6, 2

    def __init__(self) -> None:
        self.metadata, self.seen = {"task": "particle"}, []

    def act(self, observations: np.ndarray) -> np.ndarray:
        self.seen.append(np.array(observations))
        return np.zeros((len(observations), 1, 2))


def test_a_policy_controller_hands_the_systems_goal_to_the_policy():
    policy = Recording()
    controller = make_policy_controller("particle", policy, seed=0)
    try:
        state = np.array([0.1, 0.1, 0.0, 0.0])
        metadata = {
            "mocap_pos": np.array([[-0.2, 0.3, 0.0]]),
            "mocap_quat": np.array([[1.0, 0.0, 0.0, 0.0]]),
        }
        controller.update_action(state, 0.0, metadata)
    finally:
        controller.close()
    np.testing.assert_allclose(policy.seen[-1], [[0.1, 0.1, 0.0, 0.0, -0.3, 0.2]], atol=1e-15)
