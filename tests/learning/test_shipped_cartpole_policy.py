"""The distilled cartpole policy that ships in the package: it loads with onnxruntime, its metadata
says what it was trained on and how, and alone it swings the pole up and balances it on a seed it
never saw in training."""

from pathlib import Path

import numpy as np
import pytest

import judo
from judo.core.policies.policy_controller import make_policy_controller
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem

POLICY_PATH = Path(judo.__file__).parent / "tasks" / "models" / "policies" / "cartpole_action.onnx"


@pytest.fixture
def policy():
    pytest.importorskip("onnxruntime")
    return judo.OnnxPolicy(POLICY_PATH)


def test_the_shipped_policy_is_small_and_names_its_task_observation_and_training_command(policy):
    # [x, cos, sin, x_vel, w]
    assert (policy.observation_size, policy.action_size, policy.horizon) == (5, 1, 1)
    assert policy.metadata["task"] == "cartpole" and policy.metadata["kind"] == "action"
    assert policy.metadata["training_command"].startswith("python -m judo distill cartpole.h5")
    assert "--rounds 3" in policy.metadata["training_command"]
    assert POLICY_PATH.stat().st_size < 500_000


def test_alone_it_swings_up_and_balances_on_a_fresh_seed(policy):
    seed = 1000  # collect's episodes were seeds 0-39, the teacher rounds' 100000 on
    with make_policy_controller("cartpole", policy, seed=seed) as controller:
        system = MujocoSystem.from_task(controller.task, seed=seed)
        start_angle = system.task.data.qpos[1]
        result = run_episode(controller, system, duration=10.0, seed=seed)
    assert abs(np.cos(start_angle) + 1.0) < 0.1  # it started hanging
    assert result.metrics["balanced_fraction"] > 0.9 and result.failed_updates == 0
