"""Panel labels in a real browser: each fits its line or wraps between words, never inside one.

Measured in Chromium at 1400x900: every label's characters are grouped into the lines they were laid
out on (from each character's client rect), and every line break must fall at a space.
Screenshots go to test-artifacts/labels_<task>_<optimizer>.png.
"""

import itertools

import pytest

from judo.runtime.gui.field_widgets import field_label

pytestmark = pytest.mark.browser

LAYOUTS = """(labels) => labels.map((label) => {
  const lines = []; let line = ''; let top = null;
  const walker = document.createTreeWalker(label, NodeFilter.SHOW_TEXT);
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    for (let i = 0; i < node.length; i++) {
      const range = document.createRange();
      range.setStart(node, i);
      range.setEnd(node, i + 1);
      const rects = range.getClientRects();
      if (rects.length && top !== null && Math.abs(rects[0].top - top) > 2) { lines.push(line); line = ''; }
      if (rects.length) top = rects[0].top;
      line += node.data[i];
    }
  }
  lines.push(line);
  return {lines: lines, overflows: label.parentElement.scrollWidth > label.parentElement.clientWidth + 1};
})"""  # noqa: E501
"""JS, for a list of labels: the text of each line each was laid out on, and whether its box
overflows sideways (all in one round trip: a busy renderer answers each slowly)."""


def broken_inside_a_word(lines: list[str]) -> list[str]:
    """The line breaks of `lines` (a label's text as laid out) that do not fall at a space."""
    return [
        f"{a!r} | {b!r}"
        for a, b in itertools.pairwise(lines)
        if not (a.endswith(" ") or b.startswith(" "))
    ]


def test_line_breaks_are_found_only_at_spaces():
    assert broken_inside_a_word(["max num ", "traces"]) == []
    assert broken_inside_a_word(["max_num_", "traces"]) == ["'max_num_' | 'traces'"]
    assert broken_inside_a_word(["temperatu", "re"]) == ["'temperatu' | 're'"]


@pytest.mark.parametrize(("task", "optimizer"), [("cartpole", "mppi"), ("leap_cube", "cem")])
def test_every_panel_label_fits_or_wraps_between_words(
    task, optimizer, app, panel_page, wait_until, artifacts, pause_scene
):
    if task != app.session.task_name:
        app.commands.switch_task(task)
    if optimizer != app.session.optimizer_name:
        app.commands.switch_optimizer(optimizer)
    wait_until(
        lambda: (
            (app.session.task_name, app.session.optimizer_name) == (task, optimizer)
            and app.gui.shown_generation == app.session.generation
        ),
        timeout=60,
        what=f"the GUI to show {task} with {optimizer}",
    )
    page = panel_page(viewport={"width": 1400, "height": 900})
    page.set_default_timeout(60_000)
    try:
        page.goto(app.gui.url)
        page.get_by_text(f"Task: {task}", exact=True).wait_for()
        page.get_by_text(f"Optimizer: {optimizer}", exact=True).wait_for()
        pause_scene(page)
        expected = {
            field_label(name) for panel in app.gui.panels.values() for name in panel.field_names
        }
        laid_out = {
            "".join(layout["lines"]): layout
            for layout in page.locator("label[for]").evaluate_all(LAYOUTS)
        }
        assert expected <= set(laid_out), f"labels not on the page: {expected - set(laid_out)}"
        wrapped = {
            text: layout["lines"] for text, layout in laid_out.items() if len(layout["lines"]) > 1
        }
        assert wrapped  # the check sees wraps: some labels take two lines
        for text, layout in laid_out.items():
            assert broken_inside_a_word(layout["lines"]) == [], (
                f"{text!r} wraps inside a word: {layout['lines']}"
            )
            assert not layout["overflows"], f"{text!r} overflows its box"
        page.screenshot(path=artifacts / f"labels_{task}_{optimizer}.png")
    finally:
        page.close()
