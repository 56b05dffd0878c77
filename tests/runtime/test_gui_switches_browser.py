"""Rapid task switches, in a real browser: the page keeps updating and ends on the task that runs.

A frame that read the configs of a session installed after the one it rebuilt for, or that failed
part-way through a rebuild, used to leave the page with no scene and a status line that never
changed again, while the server carried on. Screenshots go to test-artifacts/switches_*.png.
"""

import re
import time

import pytest

pytestmark = [pytest.mark.browser, pytest.mark.slow]

TASKS = ["pendulum", "acrobot", "cartpole", "double_cartpole", "particle"]
SWITCHES = 20
SWITCH_PERIOD = 0.15
"""Seconds between switches: faster than a session is built, so switches land while the GUI
rebuilds."""


def readout(page) -> str:
    return page.evaluate(
        "() => [...document.querySelectorAll('p')].map(p => p.innerText).find(t => "
        "t.startsWith('sim time')) || ''"
    )


def status_text(page) -> str:
    return page.locator("p").filter(has_text=re.compile("^status:")).first.inner_text()


def test_the_page_keeps_updating_through_rapid_task_switches(
    app, panel_page, pause_scene, wait_until, artifacts
):
    page = panel_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(30_000)
    page.goto(app.gui.url)
    page.get_by_text("Controller", exact=True).wait_for()
    pause_scene(page)
    for i in range(SWITCHES):
        app.commands.switch_task(TASKS[i % len(TASKS)])
        time.sleep(SWITCH_PERIOD)
    last = TASKS[(SWITCHES - 1) % len(TASKS)]
    # The last switch may still be building its session when the GUI catches up with the one before
    # it: wait for the last one asked for (the requests merge, so the last one wins), then for the
    # GUI to show it.
    wait_until(
        lambda: (
            app.session.task_name == last and app.gui.shown_generation == app.session.generation
        ),
        timeout=30,
        what=f"the GUI to catch up with {last}",
    )
    assert app.session.task_name == last
    page.get_by_text(f"Task: {last}", exact=True).wait_for()
    wait_until(
        lambda: f"switched to {last}" in status_text(page),
        timeout=30,
        what="the page's status line",
    )
    first = readout(page)
    wait_until(
        lambda: readout(page) not in ("", first), timeout=10, what="the page's readout to update"
    )
    task_box = page.locator("label", has_text=re.compile("^task$")).first.get_attribute("for")
    dropdown = page.locator(f'[id="{task_box}"]')
    wait_until(
        lambda: dropdown.input_value() == last,
        timeout=10,
        what="the dropdown to name the task that runs",
    )
    page.screenshot(path=artifacts / "switches_end.png")
