"""Task.policy_observation: the state by default for the built-in tasks without their own, batched;
a task's own observation and its size, with sensors, mocap goals and the previous action."""

import numpy as np
import pytest

from judo.builtin import BUILTIN_TASKS
from judo.core.configuration.registry import lookup_task
from tests.conftest import UprightTask

OWN_OBSERVATION = (
    "acrobot",
    "cartpole",
    "cartpole_pd",
    "g1_stand",
    "go2_walk",
    "particle",
    "pendulum",
    "push_t",
    "quadruped_velocity",
)
"""Built-in tasks with their own observation (tests/tasks/test_policy_observations.py,
test_quadruped.py, tests/learning/test_go2_gait_search.py)."""


@pytest.mark.parametrize("name", sorted(set(BUILTIN_TASKS) - set(OWN_OBSERVATION)))
def test_the_default_observation_is_the_state_for_the_other_built_in_tasks(name):
    task = lookup_task(name)[0]()
    size = task.model.nq + task.model.nv
    states = np.random.default_rng(0).standard_normal((5, size))
    np.testing.assert_array_equal(task.policy_observation(states), states)
    assert task.policy_observation_size() == size


def test_a_task_says_what_its_policy_sees(tiny_model_path):
    class Goal(UprightTask):
        def policy_observation(
            self, states, sensors=None, system_metadata=None, previous_actions=None
        ):
            angle = sensors[:, self.get_sensor_start_index("angle")]
            return np.column_stack([np.cos(angle), np.sin(angle), states[:, 2:], previous_actions])

    task = Goal(tiny_model_path)
    assert task.policy_observation_size() == 2 + 2 + 1
    sensors = np.zeros((3, task.model.nsensordata))
    sensors[:, task.get_sensor_start_index("angle")] = [0.0, np.pi / 2, np.pi]
    observation = task.policy_observation(np.ones((3, 4)), sensors, None, np.full((3, 1), 0.5))
    np.testing.assert_allclose(observation[:, :2], [[1, 0], [0, 1], [-1, 0]], atol=1e-12)
    np.testing.assert_array_equal(observation[:, 2:], [[1, 1, 0.5]] * 3)
