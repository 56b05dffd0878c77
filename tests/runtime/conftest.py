"""Fixtures for the runtime tests: free ports, polling, and the headless Chromium the browser tests drive."""

import os
import socket
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture
def port() -> int:
    """A TCP port nothing listens on right now."""
    return _free_port()


@pytest.fixture
def app(port):
    """A running cartpole App with MPPI and its GUI on a free port (seeded, one rollout thread)."""
    from judo.runtime.app import App

    app = App("cartpole", "mppi", host="127.0.0.1", port=port, seed=0, num_workers=1)
    app.start()
    yield app
    app.stop()


@pytest.fixture
def wait_until() -> Callable[..., None]:
    """wait_until(condition, timeout, what): poll `condition()` until true, or fail saying `what` did not happen."""

    def wait(condition: Callable[[], bool], timeout: float = 10.0, what: str = "condition") -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            time.sleep(0.02)

    return wait


@pytest.fixture(scope="session")
def chromium() -> Iterator[object]:
    # Once started, playwright's sync API keeps an event loop running in the main thread for the session,
    # so a test that calls App.run() (asyncio.run) in the main thread must sort before the first browser
    # test: keep browser tests in test_gui_*_browser.py (and the like) files.
    """Debian's headless Chromium driven by playwright. Skipped when it is missing, unless $CI is set."""
    problem = None if CHROMIUM.exists() else f"{CHROMIUM} not found (install Debian's chromium package)"
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        problem = problem or "playwright is not installed (pip install -e .[dev])"
    if problem:
        if os.environ.get("CI"):
            pytest.fail(f"browser tests cannot run on CI: {problem}")
        pytest.skip(problem)
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True)
        yield browser
        browser.close()


PAUSE_THE_SCENE = """() => {
  const view = [...document.querySelectorAll('div')].find((d) => d.style.zIndex === '0' && d.querySelector('canvas'));
  if (view) view.style.transform = 'translateX(-300vw)';
  return Boolean(view);
}"""
"""JS: move the 3-D view's box out of the page's sight. viser stops drawing a scene it cannot see (its
canvas's intersection observer) and still applies every message, so the panel works as before."""


@pytest.fixture(scope="session")
def pause_scene() -> Callable[[object], None]:
    """pause_scene(page): stop `page` drawing the 3-D scene, for a test that reads the panel, not the picture.

    Headless Chromium draws WebGL in software: one page redrawing the scene at the GUI's 30 Hz keeps a
    third of a core busy, most of the CI's browser-test time. Screenshots then show the panel alone.
    """

    def pause(page) -> None:
        assert page.evaluate(PAUSE_THE_SCENE), "the page has no 3-D view to pause (has viser's layout changed?)"

    return pause


@pytest.fixture
def artifacts() -> Path:
    """The folder screenshots go to (gitignored)."""
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS
