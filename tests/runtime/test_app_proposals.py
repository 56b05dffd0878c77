"""The app refuses a policy_samples edit (the GUI's slider) when its controller has no proposal
policy."""

from pathlib import Path

import pytest

import judo


def test_the_app_refuses_policy_samples_without_a_proposal_policy_and_keeps_planning(
    app, wait_until
):
    message = (
        r"^policy_samples is 2 but the controller has no proposal policy; give one "
        r"\(make_controller\(\.\.\., "
        r"proposal_policy=\.\.\.\), evaluate --proposal-policy FILE\.onnx\) or set it to 0$"
    )
    with pytest.raises(judo.ConfigError, match=message):
        app.commands.update_config("controller", {"policy_samples": 2})
    plans = app.stats.num_plans()
    wait_until(
        lambda: app.stats.num_plans() > plans + 2, what="planning to go on with the config before"
    )


POLICY = Path(judo.__file__).parent / "tasks" / "models" / "policies" / "pendulum_chunk.onnx"


def test_the_app_plans_with_a_proposal_policy_and_its_slider_and_a_switch_drops_it(wait_until):
    pytest.importorskip("onnxruntime")
    app = judo.App("pendulum", "ps", gui=False, seed=0, num_workers=1, proposal_policy=POLICY)
    assert app.controller.proposal_policy is not None and app.controller.proposal_policy.name
    app.start()
    try:
        app.commands.update_config("controller", {"policy_samples": 4})  # the GUI's slider
        wait_until(
            lambda: app.controller.config.policy_samples == 4,
            what="the edit to reach the controller",
        )
        plans = app.stats.num_plans()
        wait_until(
            lambda: app.stats.num_plans() > plans + 3, what="plans with the policy's candidates"
        )
        assert app.status.level == "info", app.status.message
        # the policy is the pendulum's: cartpole plans without it
        app.commands.switch_task("cartpole")
        wait_until(lambda: app.session.task_name == "cartpole", timeout=30, what="the switch")
        assert app.controller.proposal_policy is None
        with pytest.raises(judo.ConfigError, match="no proposal policy"):
            app.commands.update_config("controller", {"policy_samples": 2})
    finally:
        app.stop()


def test_a_proposal_policy_for_another_task_is_refused_at_once():
    pytest.importorskip("onnxruntime")
    with pytest.raises(judo.PolicyError, match="pendulum"):
        judo.App("cartpole", "ps", gui=False, num_workers=1, proposal_policy=POLICY)
