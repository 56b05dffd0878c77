"""The first picture a user sees is the scene, not a washed-out ghost of it, in headless Chromium.

viser's page draws its 3-D view at 5 % opacity until its environment map has loaded and faded in; in
software WebGL that took 10 to 30 s, and every first screenshot showed a white haze with the robot
barely in it. The test opens the real app's page and logs, from inside the page, every change of its
canvases' opacity; once the panel is up (the scene comes with it) the view must be opaque. It also
takes a screenshot of the view as soon as the panel is up and another at least LATE_SECONDS after
the page opened, and compares their contrast (the standard deviation of the grey levels).
Screenshots go to test-artifacts/first_frame_{first,late}.png.
"""

import io
import time

import numpy as np
import pytest
from PIL import Image

pytestmark = [pytest.mark.browser, pytest.mark.slow]  # waits LATE_SECONDS for the picture to settle

LATE_SECONDS = 20.0
"""When the late screenshot is taken, counted from opening the page: the old page was clear only
after about 20 s."""
SETTLE_SECONDS = 5.0
"""The late screenshot comes at least this long after the first (which waits for a frame: long on a
loaded machine)."""
SAME_CONTRAST = 0.8
"""The first screenshot's contrast is at least this share of the late one's."""
CANVAS = (
    "[...document.querySelectorAll('canvas')].sort((a, b) => b.clientWidth * b.clientHeight - "
    "a.clientWidth * a.clientHeight)[0]"
)
"""JS expression: a canvas of the 3-D view, the largest on the page (the plots draw on small ones),
or undefined."""
LOG_OPACITY = """(() => {
  window.judoOpacity = [];
  let last = null;
  new MutationObserver(() => {
    const canvases = [...document.querySelectorAll("canvas")];
    const now = canvases.length ? Math.min(...canvases.map((c) => Number(getComputedStyle(c).opacity))) : null;
    if (now !== null && now !== last) window.judoOpacity.push([performance.now() / 1e3, now]);
    last = now;
  }).observe(document, { childList: true, subtree: true, attributes: true, attributeFilter: ["style"] });
})();"""  # noqa: E501
"""JS run before the page's own: `window.judoOpacity` lists [seconds since the page started,
opacity] at every change of the least opacity of the page's canvases (the 3-D view draws on two, the
plots on others)."""
BELOW_THE_TOAST = 160
"""CSS pixels at the top of the view left out: the "Software WebGL rendering detected" notice sits
there."""


def view_contrast(page, shot: str) -> tuple[float, float]:
    """(standard deviation, mean) of the grey levels (0-255) of the 3-D view's canvas below the
    toast in a screenshot of `page`, written to `shot`."""
    x, y, width, height = page.evaluate(
        f"(() => {{ const r = {CANVAS}.getBoundingClientRect(); return [r.x, r.y, r.width, "
        f"r.height]; }})()"
    )
    clip = {"x": x, "y": y + BELOW_THE_TOAST, "width": width, "height": height - BELOW_THE_TOAST}
    png = page.screenshot(path=shot, clip=clip)
    grey = np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=float)
    return float(grey.std()), float(grey.mean())


def test_the_scene_is_drawn_opaque_and_clear_from_the_first_screenshot(
    app, chromium, scene_url, artifacts
):
    page = chromium.new_page(viewport={"width": 1280, "height": 800})
    page.set_default_timeout(180_000)  # a page on a loaded 2-core machine takes a minute to come up
    page.add_init_script(LOG_OPACITY)
    try:
        opened = time.monotonic()
        page.goto(scene_url(app.gui.url))
        # connected: the scene came with the panel
        page.get_by_text("Controller", exact=True).wait_for()
        panel_up = page.evaluate("performance.now() / 1e3")
        first, first_mean = view_contrast(page, str(artifacts / "first_frame_first.png"))
        first_at = time.monotonic() - opened
        time.sleep(max(SETTLE_SECONDS, opened + LATE_SECONDS - time.monotonic()))
        late, late_mean = view_contrast(page, str(artifacts / "first_frame_late.png"))
        log = page.evaluate("window.judoOpacity")
    finally:
        page.close()
    assert log, "the page's 3-D canvas never had an opacity (has viser's page changed?)"
    in_force = [o for t, o in log if t <= panel_up][-1:] + [o for t, o in log if t > panel_up]
    washed = [(round(t - panel_up, 1), o) for t, o in log if o < 1 and t > panel_up]
    print(
        f"opacity in force when the panel was up and after: min {min(in_force):g}; first "
        f"screenshot at {first_at:.1f} s:"
        f" contrast {first:.1f}, mean {first_mean:.1f}; late one at "
        f"{time.monotonic() - opened:.0f} s: contrast"
        f" {late:.1f}, mean {late_mean:.1f}"
    )
    assert min(in_force) == 1.0, (
        f"the 3-D view was drawn at opacity {min(in_force):g} once the panel was up, "
        "expected 1 (seconds after the"
        f" panel, opacity: {washed[:3]} ... {washed[-1:]})"
    )
    assert late > 10, (
        f"the late screenshot has a contrast of only {late:.1f}: no scene drawn to compare with"
    )
    assert first >= SAME_CONTRAST * late, (
        f"the first screenshot ({first_at:.1f} s) had a contrast of {first:.1f}, expected at least"
        f" {SAME_CONTRAST:g} of the {late:.1f} of the late one"
    )
