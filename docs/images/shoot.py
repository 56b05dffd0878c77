"""Shoot the GUI screenshots the README and docs/tasks.md show, in headless Chromium, without browser notices.

    python docs/images/shoot.py                 # every picture
    python docs/images/shoot.py leap_cube       # one (cartpole, leap_cube, walker, quadruped, quadruped_navigate)

Needs Debian's chromium (/usr/bin/chromium) and playwright (the dev extra). Each task runs for SETTLE seconds of
wall time, with the scene drawn, before its picture is taken. viser's notices ("Software WebGL rendering detected",
which a software-rendered headless browser always gets) are closed first, so the picture shows the GUI as a user's
GPU-backed browser does.
"""

import socket
import sys
import time
from pathlib import Path

from judo.runtime.app import App

HERE = Path(__file__).resolve().parent
CHROMIUM = "/usr/bin/chromium"
SETTLE = 8.0
"""Wall seconds each task runs before its picture: traces drawn and the camera settled."""
SHOTS = {
    "cartpole": ("mppi", (1280, 900)),
    "leap_cube": ("mppi", (1400, 900)),
    "walker": ("mppi", (1400, 900)),
    "quadruped": ("mppi", (1400, 900)),
    "quadruped_navigate": ("mppi", (1400, 900)),
}
"""Task -> (optimizer, viewport) of docs/images/gui_TASK.png."""
CLOSE_NOTICES = "() => document.querySelectorAll('.mantine-Notification-closeButton').forEach((b) => b.click())"
NO_NOTICES = "() => document.querySelectorAll('.mantine-Notification-root').length === 0"


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def shoot(browser, task: str) -> Path:
    """docs/images/gui_TASK.png of `task` running in the GUI."""
    optimizer, (width, height) = SHOTS[task]
    app = App(task, optimizer, port=free_port(), seed=0)
    app.start()
    try:
        page = browser.new_page(viewport={"width": width, "height": height})
        page.set_default_timeout(120_000)
        page.goto(app.gui.url)
        page.get_by_text("Controller", exact=True).wait_for()
        deadline = time.monotonic() + SETTLE
        while time.monotonic() < deadline:  # a notice may come a moment after the page
            page.evaluate(CLOSE_NOTICES)
            page.wait_for_timeout(500)
        page.evaluate(CLOSE_NOTICES)
        page.wait_for_function(NO_NOTICES)
        page.wait_for_timeout(600)  # the close animation
        path = HERE / f"gui_{task}.png"
        page.screenshot(path=path)
        page.close()
        return path
    finally:
        app.stop()


def main(tasks: list[str]) -> None:
    from playwright.sync_api import sync_playwright

    unknown = [task for task in tasks if task not in SHOTS]
    if unknown:
        sys.exit(f"error: no picture of {unknown}; expected some of {list(SHOTS)}")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True)
        try:
            for task in tasks or list(SHOTS):
                print(shoot(browser, task))
        finally:
            browser.close()


if __name__ == "__main__":
    main(sys.argv[1:])
