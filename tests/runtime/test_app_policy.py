"""A policy as the app's controller: App(policy=...) and python -m judo --policy serve it through
the one closed loop; the optimizer dropdown hands the plant to MPC and back; the GUI names the
policy and its inference time."""

from pathlib import Path

import pytest

import judo
from judo.runtime import launch
from judo.runtime.app import App

pytest.importorskip("onnxruntime")

POLICY = Path(judo.__file__).parent / "tasks" / "models" / "policies" / "pendulum_chunk.onnx"


def test_a_policy_drives_the_app_and_the_optimizer_switches_hand_the_plant_to_mpc_and_back(
    wait_until,
):
    app = App("pendulum", "ps", gui=False, seed=0, num_workers=1, policy=POLICY)
    assert app.session.optimizer_name == "policy" and app.policy_name == "pendulum_chunk"
    assert set(app.configs()) == {"controller", "task"}  # a policy has no optimizer config
    assert app.controller.config.control_freq == float(
        judo.OnnxPolicy(POLICY).metadata["control_freq"]
    )
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() > 3, timeout=20, what="the policy's updates")
        assert app.controller.inference_ms and app.status.level == "info", app.status.message
        with pytest.raises(
            judo.ConfigError, match="a policy drives pendulum: it has no optimizer config"
        ):
            app.commands.update_config("optimizer", {"num_rollouts": 8})
        app.commands.update_config("controller", {"max_plan_age": 0.5})
        wait_until(
            lambda: app.controller.config.max_plan_age == 0.5,
            what="the edit to reach the policy's loop",
        )
        with pytest.raises(judo.JudoError, match="recording holds an optimizer's plans"):
            app.start_recording()

        app.commands.switch_optimizer("ps")  # MPC takes over the running plant
        wait_until(lambda: app.session.optimizer_name == "ps", timeout=30, what="the switch to ps")
        assert "optimizer" in app.configs() and app.controller.optimizer is not None
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() > plans + 2, timeout=20, what="MPC's plans")
        app.commands.switch_optimizer("policy")  # and back
        wait_until(
            lambda: app.session.optimizer_name == "policy", timeout=30, what="the switch back"
        )
        assert app.controller.config.control_freq == float(
            judo.OnnxPolicy(POLICY).metadata["control_freq"]
        )

        # the policy is the pendulum's: cartpole plans with the app's optimizer
        app.commands.switch_task("cartpole")
        wait_until(lambda: app.session.task_name == "cartpole", timeout=30, what="the task switch")
        assert (
            app.session.optimizer_name == "ps"
            and "switched to cartpole with ps" in app.status.message
        )
        with pytest.raises(
            judo.JudoError, match="the policy 'pendulum_chunk' is for 'pendulum', not 'cartpole'"
        ):
            app.commands.switch_optimizer("policy")
    finally:
        app.stop()


def test_an_app_without_a_policy_has_none_to_switch_to_and_a_policy_for_another_task_is_refused():
    app = App("pendulum", "ps", gui=False, num_workers=1)
    assert app.policy_name is None
    with pytest.raises(
        judo.JudoError,
        match=r"no policy to switch to: start the "
        r"app with one \(App\(policy=\.\.\.\)",
    ):
        app.commands.switch_optimizer("policy")
    app.stop()
    with pytest.raises(judo.PolicyError, match="'pendulum', not 'cartpole'"):
        App("cartpole", "ps", gui=False, num_workers=1, policy=POLICY)


def test_python_m_judo_policy_runs_headless_and_prints_the_summary(capsys):
    argv = [
        "--task",
        "pendulum",
        "--policy",
        str(POLICY),
        "--headless",
        "--duration",
        "0.5",
        "--seed",
        "0",
    ]
    assert launch.main(argv) == 0
    out = capsys.readouterr().out
    assert "task: pendulum" in out and "optimizer: policy" in out and "control rate:" in out


def test_the_gui_offers_the_policy_in_the_optimizer_dropdown_and_names_its_inference_time(
    port, wait_until
):
    app = App("pendulum", "ps", port=port, seed=0, num_workers=1, policy=POLICY)
    app.start()
    try:
        wait_until(
            lambda: app.gui.shown_generation == app.session.generation, what="the GUI to build"
        )
        controls = app.gui.controls
        assert controls.optimizer.value == "policy" and "policy" in controls.optimizer.options
        assert "ps" in controls.optimizer.options and set(app.gui.panels) == {"controller", "task"}
        wait_until(
            lambda: "policy pendulum_chunk · inference" in controls.readout.content,
            what="the readout",
        )
        # the span evaluate reports: the median of the closed loop's updates, in µs
        wait_until(
            lambda: " µs (median, as evaluate)" in controls.readout.content,
            what="an inference time",
        )
    finally:
        app.stop()
