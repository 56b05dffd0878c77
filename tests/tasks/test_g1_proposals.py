"""g1_stand's default proposals: the shipped balance policy loads in numpy (no onnxruntime), fits
the task, and its controller mixes its candidates into the optimizer's samples without being
asked."""

import sys

import numpy as np

import judo
from judo.tasks.gait_policy import GaitPolicy
from judo.tasks.unitree.g1 import POLICY_PATH, G1Stand


def test_the_shipped_balance_policy_loads_and_acts_without_onnxruntime(monkeypatch):
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # any import of them fails
    monkeypatch.setitem(sys.modules, "onnx", None)
    task = G1Stand()
    policy = task.default_proposal_policy()
    assert isinstance(policy, GaitPolicy) and policy.metadata["task"] == "g1_stand"
    assert POLICY_PATH.stat().st_size < 40_000
    policy.check_fits("g1_stand", task.policy_observation_size(), task.nu)
    task.reset()
    state = np.concatenate([task.data.qpos, task.data.qvel])[None]
    actions = policy.checked_act(task.policy_observation(state))
    assert actions.shape == (1, 1, 29) and np.isfinite(actions).all()
    # at rest and level it asks for about the standing pose (its offsets are small)
    assert np.abs(actions[0, 0] - task.home_ctrl).max() < 0.3


def test_g1_stand_s_controller_proposes_from_it_by_default():
    controller = judo.make_controller("g1_stand", "ps", seed=0, num_workers=1)
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
