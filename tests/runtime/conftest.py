"""Fixtures for the runtime tests: free ports, polling, and the headless Chromium the browser tests
drive."""

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
    """wait_until(condition, timeout, what): poll `condition()` until true, or fail saying `what`
    did not happen."""

    def wait(condition: Callable[[], bool], timeout: float = 10.0, what: str = "condition") -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            time.sleep(0.02)

    return wait


@pytest.fixture(scope="session")
def chromium() -> Iterator[object]:
    # Once started, playwright's sync API keeps an event loop running in the main thread for the
    # session, so a test that calls App.run() (asyncio.run) in the main thread must sort before the
    # first browser test: keep browser tests in test_gui_*_browser.py (and the like) files.
    """Debian's headless Chromium driven by playwright. Skipped when it is missing, unless $CI is
    set."""
    problem = (
        None if CHROMIUM.exists() else (f"{CHROMIUM} not found (install Debian's chromium package)")
    )
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


VIEW = (
    "[...document.querySelectorAll('div')].find((d) => d.style.zIndex === '0' && "
    "d.querySelector('canvas'))"
)
"""JS expression: viser's 3-D view, the box its canvas is drawn in (undefined before it is in the
page)."""
OUT_OF_SIGHT = "translateX(-300vw)"
PAUSE_THE_SCENE = f"""() => {{
  const view = {VIEW};
  if (view) view.style.transform = '{OUT_OF_SIGHT}';
  return Boolean(view);
}}"""
"""JS: move the 3-D view's box out of the page's sight. viser stops drawing a scene it cannot see
(its canvas's intersection observer) and still applies every message, so the panel works as
before."""
NEVER_DRAW_THE_SCENE = f"""(() => {{
  let view = null;
  new MutationObserver(() => {{
    if (view && view.isConnected) return;
    view = {VIEW};
    if (view) view.style.transform = '{OUT_OF_SIGHT}';
  }}).observe(document, {{ childList: true, subtree: true }});
}})();"""
"""JS run before the page's own: move the 3-D view out of sight as soon as it is in the page (and
again if it is ever made anew). viser's canvas starts as not in view, so the scene is never drawn,
not even its first frames."""


@pytest.fixture(scope="session")
def pause_scene() -> Callable[[object], None]:
    """pause_scene(page): stop `page` drawing the 3-D scene, for a test that reads the panel, not
    the picture.

    Headless Chromium draws WebGL in software: one page drawing the scene takes all the CPU it gets
    (a frame of a quadruped at 1280x900 costs its GPU process about half a core-second), most of the
    CI's browser-test time. Screenshots then show the panel alone. A page from `panel_page` never
    draws it.
    """

    def pause(page) -> None:
        assert page.evaluate(PAUSE_THE_SCENE), (
            "the page has no 3-D view to pause (has viser's layout changed?)"
        )

    return pause


@pytest.fixture(scope="session")
def panel_page(chromium) -> Callable[..., object]:
    """panel_page(**kwargs): `chromium.new_page(**kwargs)` that never draws the 3-D scene, from its
    first frame: for a test that reads the panel, not the picture. Call `pause_scene(page)` once it
    is up, which fails if the page has no 3-D view (the pause would then have silently done
    nothing)."""

    def new_page(**kwargs):
        page = chromium.new_page(**kwargs)
        page.add_init_script(NEVER_DRAW_THE_SCENE)
        return page

    return new_page


SCENE_DPR = 0.5
"""Device pixels per CSS pixel the 3-D view is drawn at in tests that look at the scene (viser's
`fixedDpr` page option; left alone, viser picks 1 and drops to 0.75 when frames are slow). A frame
of a quadruped at 1280x800 costs the software GPU process about half a core-second at 1: every
screenshot waits for one, and the page's camera moves once a frame. The view's size and camera are
the same at any DPR (its aspect to within a pixel's rounding): only its pixels are fewer."""


@pytest.fixture(scope="session")
def scene_url() -> Callable[[str], str]:
    """scene_url(url): the GUI at `url` with its 3-D view drawn at SCENE_DPR, for a test that looks
    at the scene."""

    def with_dpr(url: str) -> str:
        return f"{url}{'&' if '?' in url else '?'}fixedDpr={SCENE_DPR:g}"

    return with_dpr


@pytest.fixture
def artifacts() -> Path:
    """The folder screenshots go to (gitignored)."""
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS
