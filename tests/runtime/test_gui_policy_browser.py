"""A policy in the GUI, in headless Chromium: the page names the policy and its inference time (the
closed loop's update, the span evaluate reports), offers "policy" in the optimizer dropdown, and
shows the policy_samples slider of a controller with a proposal policy."""

from pathlib import Path

import pytest

import judo
from judo.runtime.app import App

pytestmark = pytest.mark.browser

POLICY = Path(judo.__file__).parent / "tasks" / "models" / "policies" / "pendulum_chunk.onnx"


def test_the_page_names_the_driving_policy_its_inference_time_and_the_proposals_slider(
    port, panel_page, pause_scene, wait_until, artifacts
):
    pytest.importorskip("onnxruntime")
    app = App(
        "pendulum", "ps", port=port, seed=0, num_workers=1, policy=POLICY, proposal_policy=POLICY
    )
    app.start()
    page = panel_page(viewport={"width": 1400, "height": 900})
    page.set_default_timeout(60_000)
    try:
        wait_until(lambda: app.stats.num_plans() > 2, timeout=30, what="the policy's updates")
        page.goto(app.gui.url)
        page.get_by_text("Task: pendulum", exact=True).wait_for()
        pause_scene(page)
        # the readout, with a time once there is one
        page.get_by_text("policy pendulum_chunk · inference").wait_for()
        readout = page.get_by_text("policy pendulum_chunk · inference").inner_text()
        # the span evaluate reports, in µs on the page
        inference = app.session.closed_loop.update_ms
        assert " µs (median, as evaluate)" in readout.split("inference")[1], readout
        assert (
            1e3 * min(inference)
            <= float(readout.split("inference ")[1].split(" µs")[0])
            <= 1e3 * max(inference)
        )
        # a policy has no optimizer panel
        assert page.get_by_text("Optimizer:", exact=False).count() == 0
        page.screenshot(path=artifacts / "policy_pendulum.png")

        # MPC with the policy's proposals: the optimizer panel and the slider
        app.commands.switch_optimizer("ps")
        wait_until(
            lambda: (
                app.gui.shown_generation == app.session.generation
                and app.session.optimizer_name == "ps"
            )
        )
        page.get_by_text("Optimizer: ps", exact=True).wait_for()
        page.get_by_text("policy samples", exact=False).first.wait_for()
        page.get_by_text("· plan ", exact=False).wait_for()  # the readout names the plan time again
        app.commands.update_config("controller", {"policy_samples": 4})
        wait_until(
            lambda: app.controller.config.policy_samples == 4, what="the proposals to be in force"
        )
    finally:
        page.close()
        app.stop()
