"""The estimate in a real browser (headless Chromium): the ghost of the estimated robot is drawn
over the true one and follows the estimate, and the estimation-error chart updates. Screenshots go
to test-artifacts/."""

import io
import re

import mujoco
import numpy as np
import pytest
from PIL import Image

from judo.runtime.app import App

# 13-17 s: the scene drawn, screenshots compared
pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def sensed_app(port):
    """A running cartpole App observing its encoders (noisy, 10 ms late, 100 Hz) through the EKF,
    with its GUI."""
    app = App(
        "cartpole",
        "mppi",
        port=port,
        seed=0,
        num_workers=1,
        observe="sensors",
        sensor_noise=0.01,
        sensor_delay=0.01,
        sensor_rate=100,
    )
    app.start()
    yield app
    app.stop()


def pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


def test_the_ghost_follows_the_estimate_and_the_error_chart_updates(
    sensed_app, chromium, wait_until, artifacts, scene_url, pause_scene
):
    app, gui = sensed_app, sensed_app.gui
    page = chromium.new_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(60_000)
    try:
        page.goto(scene_url(gui.url))
        page.get_by_text("Estimator: ekf", exact=True).wait_for()
        wait_until(lambda: len(gui.server.get_clients()) == 1, what="the page to connect")
        assert page.get_by_text("Noise jointpos").count() >= 1  # the estimator's sliders

        # the ghost's nodes exist and are posed from the estimate, the robot's from the truth
        wait_until(
            lambda: gui.ghost is not None and gui.plots.estimation is not None,
            what="the ghost and chart",
        )
        model = app.session.controller.task.model
        data = mujoco.MjData(model)
        app.commands.pause()
        page.wait_for_timeout(500)
        snapshot = app.buffer.latest("system").value
        data.qpos[:] = snapshot.reading.state[: model.nq]
        mujoco.mj_kinematics(model, data)
        wait_until(
            lambda: np.allclose(gui.ghost.body_frames[2].wxyz, data.xquat[2], atol=1e-6),
            what="the ghost's pole posed from the estimate",
        )
        # an estimate, not the truth
        assert not np.allclose(snapshot.reading.state, snapshot.true_state)

        # the page draws it: hiding the ghost changes the picture of the paused scene
        canvas = page.locator("canvas").first
        page.wait_for_timeout(1000)
        with_ghost = pixels(canvas.screenshot(path=artifacts / "gui_estimate_ghost.png"))
        for frame in gui.ghost.body_frames.values():
            frame.visible = False
        page.wait_for_timeout(1000)
        without_ghost = pixels(canvas.screenshot())
        changed = np.abs(with_ghost - without_ghost).sum(axis=2) > 30
        assert changed.sum() > 200, f"only {changed.sum()} pixels changed when the ghost was hidden"
        tint = with_ghost[changed] - without_ghost[changed]
        assert tint[:, 2].mean() > tint[:, 0].mean()  # the ghost tints the robot blue
        for frame in gui.ghost.body_frames.values():
            frame.visible = True

        # the rest reads the panel: the scene stops being drawn (a screenshot waits for a frame of
        # it)
        pause_scene(page)

        # the estimation-error chart is on the page and redraws as points come in
        app.commands.resume()
        chart = page.locator(".uplot", has=page.locator(".u-title", has_text="estimation error"))
        chart.scroll_into_view_if_needed()
        # wall time of the newest point (the chart keeps the last 120)
        last = gui.plots.estimation.data[0][-1]
        before = chart.screenshot()
        wait_until(
            lambda: gui.plots.estimation.data[0][-1] >= last + 1.0,
            timeout=20,
            what="new error points",
        )
        page.wait_for_timeout(500)
        after = chart.screenshot(path=artifacts / "gui_estimation_error.png")
        assert before != after
        legend = chart.locator(".u-legend").inner_text()
        assert "position" in legend and "velocity" in legend

        # the estimator dropdown: "state" cannot read encoders-only readings, so it is refused and
        # put back
        label = page.locator("label", has_text=re.compile("^estimator$")).first
        dropdown = page.locator(f'[id="{label.get_attribute("for")}"]')
        dropdown.click(force=True)
        page.get_by_role("option", name="state", exact=True).click(force=True)
        wait_until(
            lambda: "estimator not switched" in app.status.message, timeout=30, what="the refusal"
        )
        wait_until(lambda: gui.controls.estimator.value == "ekf", what="the dropdown put back")
        assert app.session.generation == 0 and app.session.estimator_name == "ekf"
    finally:
        page.close()
