"""The latched stop in the GUI, in headless Chromium: the Stop button latches it (the plant is
served the safe action), a page that reconnects is shown it, Clear stop clears it, and the Escape
key latches it from anywhere on the page. Screenshot: test-artifacts/stop_latched.png.

Playwright runs on a thread of its own here: its sync API keeps an event loop on the thread that
starts it, and tests/runtime's session browser may already hold the main thread's.
"""

import importlib.util
import os
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from judo.runtime.app import App

pytestmark = [pytest.mark.browser, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "judo_runtime_browser_fixtures", ROOT / "tests" / "runtime" / "conftest.py"
)
assert _spec is not None and _spec.loader is not None
browser_fixtures = importlib.util.module_from_spec(_spec)
# its Chromium path and the script that keeps the 3-D scene undrawn
_spec.loader.exec_module(browser_fixtures)


def in_browser(work, timeout: float = 300.0):
    """work(browser) with Debian's headless Chromium, on a thread of its own; what it returns, or
    what it raised."""
    chromium = browser_fixtures.CHROMIUM
    problem = (
        None if chromium.exists() else (f"{chromium} not found (install Debian's chromium package)")
    )
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        problem = problem or "playwright is not installed (pip install -e .[dev])"
    if problem:
        if os.environ.get("CI"):
            pytest.fail(f"browser tests cannot run on CI: {problem}")
        pytest.skip(problem)
    outcome: dict[str, object] = {}

    def run() -> None:
        try:
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(executable_path=str(chromium), headless=True)
                try:
                    outcome["value"] = work(browser)
                finally:
                    browser.close()
        except BaseException as err:  # handed to the test's thread
            outcome["error"] = err

    thread = threading.Thread(target=run, name="stop-browser", daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive():
        pytest.fail(f"the browser did not finish within {timeout} s")
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    return outcome.get("value")


def wait_until(condition, timeout: float = 60.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.02)


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Served:
    """Every action the closed loop served."""

    def __init__(self) -> None:
        self.actions: list[np.ndarray] = []

    def on_plan(self, record) -> None:
        pass

    def on_step(self, record) -> None:
        self.actions.append(np.array(record.action))


def test_the_stop_button_the_clear_button_and_the_escape_key(tmp_path):
    stop_file = tmp_path / "stop.json"
    app = App("cartpole", "mppi", port=free_port(), seed=0, num_workers=1, stop_file=stop_file)
    served = Served()
    app.session.closed_loop.recorders.append(served)
    app.start()
    latch = app.stop_latch
    artifacts = ROOT / "test-artifacts"
    artifacts.mkdir(exist_ok=True)

    def drive(browser) -> None:
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.add_init_script(browser_fixtures.NEVER_DRAW_THE_SCENE)
        page.set_default_timeout(60_000)
        page.goto(app.gui.url)
        page.get_by_text("Controller", exact=True).wait_for()
        wait_until(
            lambda: any(np.any(a != 0) for a in served.actions[-20:]), what="the plan served"
        )

        page.get_by_role("button", name="Stop", exact=True).click()
        wait_until(
            lambda: latch.latest is not None and latch.latest.effect_s is not None,
            what="the stop's effect",
        )
        index = len(served.actions)
        # the page shows it latched
        page.get_by_role("button", name="STOPPED", exact=True).wait_for()
        wait_until(lambda: len(served.actions) > index + 20, what="steps under the stop")
        assert np.all(np.array(served.actions[index:]) == 0.0), "cartpole's safe action is 0"
        assert stop_file.exists()
        page.screenshot(path=artifacts / "stop_latched.png")
        page.reload()  # a page that connects while latched is shown it
        page.get_by_role("button", name="STOPPED", exact=True).wait_for()
        assert latch.latched

        page.get_by_role("button", name="Clear stop", exact=True).click()
        wait_until(lambda: not latch.latched, what="the clear")
        page.get_by_role("button", name="Stop", exact=True).wait_for()
        assert not stop_file.exists()

        page.get_by_text("Controller", exact=True).click()  # the page has the focus, no widget
        page.keyboard.press("Escape")
        wait_until(lambda: latch.latched, what="the Escape key's latch")
        page.close()

    try:
        in_browser(drive)
    finally:
        app.stop()
    sources = [(event.source, event.engaged) for event in latch.events]
    assert sources == [
        ("the GUI's Stop button", True),
        ("the GUI's Clear stop button", False),
        ("the GUI's Escape key", True),
    ]
