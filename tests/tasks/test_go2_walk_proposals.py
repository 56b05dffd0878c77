"""go2_walk's default proposals: the shipped trot gait policy loads in numpy (no onnxruntime), fits
the task, and its controller mixes its candidates into the optimizer's samples without being asked;
other tasks' controllers get none."""

import sys

import numpy as np

import judo
from judo.core.policy import Policy
from judo.tasks.gait_policy import GaitPolicy
from judo.tasks.unitree.go2 import POLICY_PATH, Go2Walk


def test_the_shipped_gait_policy_loads_and_acts_without_onnxruntime(monkeypatch):
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # any import of them fails
    monkeypatch.setitem(sys.modules, "onnx", None)
    task = Go2Walk()
    policy = task.default_proposal_policy()
    assert isinstance(policy, GaitPolicy) and policy is task.default_proposal_policy()
    assert POLICY_PATH.stat().st_size < 20_000 and policy.metadata["task"] == "go2_walk"
    policy.check_fits("go2_walk", task.policy_observation_size(), task.nu)
    task.reset()
    mujoco_state = np.concatenate([task.data.qpos, task.data.qvel])[None]
    observation = task.policy_observation(mujoco_state, task.data.sensordata[None])
    actions = policy.checked_act(observation)
    assert actions.shape == (1, 1, 12) and np.isfinite(actions).all()


def test_go2_walk_s_controller_proposes_from_it_by_default():
    controller = judo.make_controller("go2_walk", "mppi", seed=0, num_workers=1)
    try:
        assert isinstance(controller.proposal_policy, GaitPolicy)
        assert 0 < controller.config.policy_samples < controller.optimizer.config.num_rollouts
        task = controller.task
        task.reset()
        state = np.concatenate([task.data.qpos, task.data.qvel])
        controller.update_action(state, 0.0)
        assert controller._proposer.last_error is None  # the update had its proposals
        assert np.isfinite(controller.nominal_knots).all()
    finally:
        controller.close()


def test_a_given_proposal_policy_wins_and_other_tasks_get_none():
    class Still(Policy):
        observation_size, action_size, metadata = 35, 12, {"task": "go2_walk"}

        def act(self, observations):
            return np.zeros((len(observations), 1, 12))

    still = Still()
    controller = judo.make_controller("go2_walk", "mppi", num_workers=1, proposal_policy=still)
    assert controller.proposal_policy is still
    controller.close()
    stand = judo.make_controller("go2_stand", "mppi", num_workers=1)
    assert stand.proposal_policy is None
    stand.close()
