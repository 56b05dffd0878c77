"""cartpole_pd: the MPC plans the cart's target, a PD law written as an ONNX graph turns it into the
push, and the pole swings up and balances in `evaluate` (seeded, sim time)."""

import json

import numpy as np

from judo.core.configuration.registry import make_controller
from judo.core.policies.onnx_policy import OnnxPolicy
from judo.core.rollouts.low_level_rollout import LowLevelRollout
from judo.evaluation.evaluate import main
from judo.loop.system import MujocoSystem
from judo.tasks.cartpole_pd import EVERY, TARGET_RANGE, CartpolePD, pd_policy_path, pd_weight


def test_the_policy_file_is_the_pd_law():
    policy = OnnxPolicy(pd_policy_path())
    assert (policy.observation_size, policy.action_size, policy.horizon) == (5, 1, 1)
    assert policy.metadata["task"] == "cartpole_pd"
    observations = np.random.default_rng(0).normal(size=(300, 5))
    np.testing.assert_allclose(
        policy.act(observations)[:, 0], observations @ pd_weight().T, rtol=1e-6, atol=1e-6
    )


def test_the_task_plans_targets_and_the_plant_runs_the_policy():
    task = CartpolePD()
    assert (task.nu, task.command_size, task.low_level().every) == (1, 1, EVERY)
    np.testing.assert_array_equal(task.command_range, [TARGET_RANGE])
    with make_controller("cartpole_pd", "ps", seed=0, num_workers=1) as controller:
        assert isinstance(controller.backend, LowLevelRollout)
    plant = MujocoSystem.from_task(task, seed=0)
    x, _, x_vel, _ = plant.plant_state()
    plant.apply(np.array([1.0]))  # a target 1 m to the right
    plant.step()
    np.testing.assert_allclose(
        plant.task.data.ctrl, pd_weight() @ [1.0, x, 0.0, x_vel, 0.0], rtol=1e-6
    )


def test_it_swings_up_and_balances_in_evaluate(tmp_path):
    report_path = tmp_path / "eval.json"
    args = [
        "--task",
        "cartpole_pd",
        "--optimizer",
        "ps",
        "--seeds",
        "1",
        "--duration",
        "4.5",
        "--num-workers",
        "1",
    ]
    assert main([*args, "--optimizer-config.num-rollouts", "32", "--json", str(report_path)]) == 0
    metrics = json.loads(report_path.read_text())["episodes"][0]["metrics"]
    # Swung up within about 1.1 s (seeds 0-2), then balanced and centred over the final 3 s.
    assert metrics["swung_up"] == 1.0 and metrics["balanced_fraction"] > 0.95
