"""Long commands show their progress where stderr is no terminal (a pipe, a log file, CI): a plain
line every few seconds with what is done of the total, the time elapsed and the time left, and
rich's bar on a terminal."""

import io
import queue
import re
import signal
import subprocess
import sys
import threading
import time

import pytest
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from judo.cli_shared import PROGRESS_PERIOD, ProgressLines, clock_time, progress_display

LINE = re.compile(
    r"\| (?P<done>[\d.]+)/(?P<total>[\d.]+), elapsed (?P<elapsed>[\d:]+), ETA "
    r"(?P<eta>[\d:]+|unknown)$"
)
"""A progress line's figures: done/total, elapsed and ETA."""


def wait_for_output(stream: io.StringIO, pattern: str, timeout: float = 30.0) -> str:
    """The first line of `stream` so far that matches `pattern`, waiting up to `timeout` s for
    it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = [line for line in stream.getvalue().splitlines() if re.search(pattern, line)]
        if found:
            return found[0]
        time.sleep(0.02)
    pytest.fail(f"no line matching {pattern!r} within {timeout} s; printed: {stream.getvalue()!r}")


def test_the_display_is_richs_bar_on_a_terminal_and_plain_lines_elsewhere():
    assert (
        type(progress_display(console=Console(file=io.StringIO(), force_terminal=True))) is Progress
    )
    assert isinstance(progress_display(console=Console(file=io.StringIO())), ProgressLines)


def test_plain_lines_say_what_is_done_of_the_total_the_time_elapsed_and_left_while_the_work_runs():
    out = io.StringIO()
    with ProgressLines(
        TextColumn("{task.description}"), BarColumn(), console=Console(file=out), period=0.05
    ) as shown:
        task = shown.add_task("fitting", total=4)
        first = wait_for_output(out, r"^fitting \| 0/4, elapsed")
        assert first.endswith("ETA unknown"), first  # nothing done yet: no rate to go by
        shown.update(task, completed=2, description="fitting: 2 windows")
        line = wait_for_output(out, r"^fitting: 2 windows \| 2/4, elapsed")
        figures = LINE.search(line)
        assert figures is not None and figures["eta"] != "unknown", line
        printed = len(out.getvalue())
    time.sleep(0.2)  # stopped: nothing more is printed
    assert len(out.getvalue()) == printed


def test_plain_lines_without_a_total_give_the_time_elapsed():
    out = io.StringIO()
    with ProgressLines(
        TextColumn("{task.description}"), console=Console(file=out), period=0.05
    ) as shown:
        shown.add_task("fitting 2 parameters: 40 residual evaluations", total=None)
        line = wait_for_output(
            out,
            r"^fitting 2 parameters: 40 residual "
            r"evaluations \| elapsed \d+:\d\d$",
        )
    assert "ETA" not in line


def test_short_work_prints_no_line_and_times_read_as_a_clock():
    out = io.StringIO()
    with ProgressLines(TextColumn("{task.description}"), console=Console(file=out)) as shown:
        shown.add_task("quick", total=1)
    assert out.getvalue() == ""
    assert (clock_time(5.4), clock_time(125), clock_time(3725)) == ("0:05", "2:05", "1:02:05")


def stderr_lines(process: subprocess.Popen) -> "queue.Queue[tuple[float, str, bool]]":
    """(monotonic time, line, whether the process was still running) for each line of `process`'s
    stderr, as it arrives (a reader thread)."""
    lines: queue.Queue[tuple[float, str, bool]] = queue.Queue()

    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            lines.put((time.monotonic(), line.rstrip("\n"), process.poll() is None))

    threading.Thread(target=read, daemon=True).start()
    return lines


@pytest.mark.slow
def test_evaluate_with_its_output_piped_prints_progress_lines_during_the_episode():
    """An episode of 120 s of sim time takes minutes on a loaded machine; the test reads two
    progress lines from the pipe while evaluate runs, then stops it with Ctrl-C."""
    argv = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--seeds",
        "1",
        "--duration",
        "120",
        "--num-workers",
        "1",
    ]
    evaluate = subprocess.Popen(
        [sys.executable, "-m", "judo", "evaluate", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines, progress = stderr_lines(evaluate), []
        # the start (imports, the model) and two lines
        deadline = time.monotonic() + 120 + 2 * PROGRESS_PERIOD
        while len(progress) < 2 and time.monotonic() < deadline:
            try:
                _, line, running = lines.get(timeout=1.0)
            except queue.Empty:
                continue
            if (figures := LINE.search(line)) is not None:
                progress.append((line, figures, running))
        assert len(progress) == 2, (
            f"evaluate printed {len(progress)} progress lines to its pipe in 2 minutes"
        )
        assert all(running for _, _, running in progress), (
            "the progress lines came only when evaluate had ended"
        )
        (first, a, _), (second, b, _) = progress
        assert first.startswith("seed 0") and float(a["total"]) == 120.0, first
        assert float(b["done"]) > float(a["done"]), (
            f"the episode did not advance between two lines: {first!r}, {second!r}"
        )
    finally:
        evaluate.send_signal(signal.SIGINT)
        try:
            evaluate.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            evaluate.kill()
            evaluate.communicate()
