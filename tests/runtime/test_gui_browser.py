"""The GUI in a real browser (headless Chromium): panels, a slider, a refused edit, the optimizer
dropdown.

Screenshots go to test-artifacts/.
"""

import re

import pytest

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import make_config
from judo.runtime.gui.field_widgets import field_label

pytestmark = pytest.mark.browser


@pytest.fixture
def page(panel_page, app, pause_scene):
    page = panel_page(viewport={"width": 1280, "height": 900})
    # software WebGL on a busy machine can be slow; an idle one takes seconds
    page.set_default_timeout(60_000)
    page.goto(app.gui.url)
    page.get_by_text("Controller", exact=True).wait_for()
    pause_scene(page)
    # e.g. the "software WebGL" notice
    for close in page.locator(".mantine-Notification-closeButton").all():
        close.dispatch_event("click")
    yield page
    page.close()


def labelled(page, label: str, role: str):
    """The element with `role` inside the widget whose label reads exactly `label`."""
    target = page.locator(
        "label", has_text=re.compile(f"^{re.escape(field_label(label))}$")
    ).first.get_attribute("for")
    widget = page.locator(f'[id="{target}"]')
    return widget if widget.get_attribute("role") == role else widget.locator(f'[role="{role}"]')


def test_panels_show_every_config_field(app, page, artifacts):
    # one round trip: a busy renderer answers slowly
    labels = page.locator("label").all_inner_texts()
    texts = page.locator(".mantine-Paper-root").first.inner_text()
    for panel in app.gui.panels.values():
        for name in panel.field_names:
            assert labels.count(field_label(name)) == 1, name
    for text in (
        "Controller",
        "Optimizer: mppi",
        "Task: cartpole",
        "Plots",
        "Pause",
        "Reset task",
        "Reset configs",
    ):
        assert text in texts
    # also after "fresh plans are served again: " (a slow first plan)
    assert "running cartpole with mppi" in texts
    page.wait_for_timeout(1500)  # let the scene and plots fill in
    page.screenshot(path=artifacts / "gui_cartpole_mppi.png")
    page.get_by_text("real-time factor", exact=True).scroll_into_view_if_needed()
    page.screenshot(path=artifacts / "gui_plots.png")


def click_slider(page, label: str, low: float, high: float, value: float):
    """Click the track of the slider labelled `label` (range low..high) where `value` sits; return
    its thumb."""
    track = labelled(page, label, "slider").locator(
        "xpath=ancestor::div[contains(@class, 'mantine-Slider-root')]"
    )
    track.scroll_into_view_if_needed()  # a click outside the viewport reaches nothing
    box = track.locator(".mantine-Slider-track").bounding_box()
    assert box is not None
    page.mouse.click(
        box["x"] + box["width"] * (value - low) / (high - low), box["y"] + box["height"] / 2
    )
    return labelled(page, label, "slider")


def test_moving_a_slider_changes_the_controllers_config(app, page, wait_until, artifacts):
    default = app.controller.config.horizon
    assert default == make_config(ControllerConfig, "cartpole").horizon
    thumb = click_slider(page, "horizon", 0.05, 5.0, 2.5)
    wait_until(
        lambda: float(thumb.get_attribute("aria-valuenow")) != default,
        timeout=60,
        what="the slider to move",
    )
    shown = float(thumb.get_attribute("aria-valuenow"))
    assert 2.0 <= shown <= 3.0
    # the page may show the value nudged by a billionth (every page is made to redraw an applied
    # edit)
    wait_until(
        lambda: abs(app.controller.config.horizon - shown) < 1e-6,
        timeout=60,
        what=f"the horizon {shown}",
    )
    page.screenshot(path=artifacts / "gui_slider_moved.png")


def test_an_invalid_edit_is_refused_and_the_widget_goes_back(app, page, wait_until, artifacts):
    # 3 knots: too few for cartpole's cubic spline
    thumb = click_slider(page, "num_nodes", 2, 20, 3)
    message = "edit refused: a cubic spline needs num_nodes >= 4, got 3"
    page.get_by_text(f"status: warning: {message}").wait_for()
    wait_until(
        lambda: thumb.get_attribute("aria-valuenow") == "4",
        timeout=60,
        what="the slider to go back to 4",
    )
    assert (
        app.configs()["optimizer"].num_nodes == 4 and app.controller.optimizer.config.num_nodes == 4
    )
    page.screenshot(path=artifacts / "gui_edit_refused.png")


def test_switching_the_optimizer_dropdown_rebuilds_its_panel(app, page, wait_until, artifacts):
    scene = app.gui.scene
    # force: skip waiting for stable animation frames
    labelled(page, "optimizer", "combobox").click(force=True)
    page.get_by_role("option", name="cem", exact=True).click(force=True)
    page.get_by_text("Optimizer: cem", exact=True).wait_for()
    wait_until(
        lambda: app.session.optimizer_name == "cem", timeout=60, what="the app to switch to cem"
    )
    assert isinstance(app.controller.optimizer, judo.get_registered_optimizers()["cem"][0])
    for name in ("sigma_min", "sigma_max", "num_elites"):
        page.locator("label", has_text=re.compile(f"^{field_label(name)}$")).wait_for()
    assert page.locator("label", has_text=re.compile("^temperature$")).count() == 0
    assert page.get_by_text("Optimizer: mppi", exact=True).count() == 0
    assert app.gui.scene is scene  # same task: the scene and the user's camera stay
    page.wait_for_timeout(1000)
    page.screenshot(path=artifacts / "gui_switched_to_cem.png")
