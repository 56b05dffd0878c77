"""tools/width: the rewrapper that brings a tree to 100 columns changes no behaviour, and wraps what
it says."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "tools" / "width"

SOURCE = '''"""A module whose docstring runs on and on past the width of one line, with enough words in it that a reflow must cut it."""


def message(name: str) -> str:
    """A function."""
    # a full-line comment that goes on well past the hundredth column, so that the tool must re-flow it onto two lines
    value = 1  # a trailing comment that pushes the line past the hundredth column, so the tool moves it above the code
    return f"the value {value} of {name} is what it was, and this sentence carries on past the hundredth column here"
'''  # noqa: E501


def test_the_rewrapper_keeps_behaviour_and_wraps_comments_docstrings_and_strings(tmp_path):
    path = tmp_path / "sample.py"
    path.write_text(SOURCE)
    subprocess.run(
        [sys.executable, str(TOOLS / "rewrap.py"), str(path)], check=True, capture_output=True
    )
    after = path.read_text()
    assert after != SOURCE
    assert max(len(line) for line in after.splitlines()) <= 100, after
    sys.path.insert(0, str(TOOLS))
    try:
        from equiv import compare
    finally:
        sys.path.remove(str(TOOLS))
    assert compare(SOURCE, after) is None
    namespace: dict = {}
    exec(compile(after, "sample.py", "exec"), namespace)
    assert namespace["message"]("x") == (
        "the value 1 of x is what it was, and this sentence carries on past the hundredth "
        "column here"
    )
    # the check does see a change
    assert compare(SOURCE, after.replace("value = 1", "value = 2")) is not None
