"""Every slider of quadruped_navigate dragged to its right end and back with the mouse, in a real browser: the
app keeps serving (a plan at most a bounded time later, the page's status and readout still updating), because an
edit whose planning cycle would exceed MAX_CYCLE_SECONDS is refused and the cycles in flight are cancelled.

Screenshots go to test-artifacts/sliders_*.png.
"""

import re
import time

import pytest

from judo.runtime.app import App
from judo.runtime.cycles import MAX_CYCLE_SECONDS

pytestmark = [pytest.mark.browser, pytest.mark.slow]

SERVING_BOUND = 3 * MAX_CYCLE_SECONDS
"""Seconds within which the app plans again after the drags (an estimated 10 s cycle, on a loaded machine)."""


@pytest.fixture
def quadruped(port):
    app = App("quadruped_navigate", "mppi", port=port, seed=0, num_workers=2)
    app.start()
    yield app
    app.stop()


def status_text(page) -> str:
    return page.locator("p").filter(has_text=re.compile("^status:")).first.inner_text()


def drag(page, thumb, to_x: float) -> None:
    """Press the mouse on `thumb` and drag it to page x `to_x` in a few moves, as a hand does."""
    thumb.scroll_into_view_if_needed()
    box = thumb.bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(to_x, y, steps=4)
    page.mouse.up()


def test_every_slider_dragged_to_its_end_and_back_leaves_the_app_serving(
    quadruped, panel_page, pause_scene, wait_until, artifacts
):
    app = quadruped
    page = panel_page(viewport={"width": 1280, "height": 2400})  # tall: every slider without scrolling
    page.set_default_timeout(60_000)
    page.goto(app.gui.url)
    page.get_by_text("Controller", exact=True).wait_for()
    pause_scene(page)
    wait_until(lambda: app.stats.num_plans() >= 1, timeout=30, what="the first plan")
    thumbs = page.locator('[role="slider"]')
    count = thumbs.count()
    assert count >= 15  # the controller's, the optimizer's and the task's sliders
    starts, ends = [], []
    for i in range(count):
        thumb = thumbs.nth(i)
        track = thumb.locator("xpath=..").bounding_box()
        box = thumb.bounding_box()
        starts.append(box["x"] + box["width"] / 2)
        ends.append(track["x"] + track["width"] + 40)  # past the right end: the thumb stops at the end
    for i in range(count):
        drag(page, thumbs.nth(i), ends[i])
    page.wait_for_timeout(1500)  # every edit settled (0.5 s) and a refusal reported (1.5 s)
    page.screenshot(path=artifacts / "sliders_right.png")
    size = app.planning_cost()
    assert size.estimate <= MAX_CYCLE_SECONDS  # the edits that would have made it longer were refused
    for i in range(count):
        drag(page, thumbs.nth(i), starts[i])
    dragged_back = time.monotonic()
    plans = app.stats.num_plans()
    wait_until(lambda: app.stats.num_plans() > plans, timeout=SERVING_BOUND, what="a plan after the drags")
    before = status_text(page)
    page.get_by_role("button", name="Pause").click()
    wait_until(lambda: "paused" in status_text(page), timeout=10, what="the page to show the pause")
    cycle = app._state.cycle
    assert app.paused and (cycle is None or cycle.is_set())  # a pause cancels the cycle in flight
    page.get_by_role("button", name="Resume").click()
    wait_until(lambda: not app.paused, timeout=10, what="the resume")
    resumed = app.stats.num_plans()
    wait_until(lambda: app.stats.num_plans() > resumed, timeout=SERVING_BOUND, what="a plan after the resume")
    assert time.monotonic() - dragged_back < 2 * SERVING_BOUND + 20
    assert before  # the status line was shown throughout
    page.screenshot(path=artifacts / "sliders_back.png")
