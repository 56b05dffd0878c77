"""The app refuses a policy_samples edit (the GUI's slider) when its controller has no proposal policy."""

import pytest

import judo


def test_the_app_refuses_policy_samples_without_a_proposal_policy_and_keeps_planning(app, wait_until):
    message = (
        r"^policy_samples is 2 but the controller has no proposal policy; give one \(make_controller\(\.\.\., "
        r"proposal_policy=\.\.\.\), evaluate --proposal-policy FILE\.onnx\) or set it to 0$"
    )
    with pytest.raises(judo.ConfigError, match=message):
        app.update_config("controller", {"policy_samples": 2})
    plans = app.stats.num_plans()
    wait_until(lambda: app.stats.num_plans() > plans + 2, what="planning to go on with the config before")
