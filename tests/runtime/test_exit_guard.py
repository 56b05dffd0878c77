"""A script that ends or raises without `app.stop()` exits cleanly: the exit hook stops the App
before the interpreter finalizes under its rollout threads (which segfaulted, rc 139, in most
runs)."""

import subprocess
import sys
import textwrap

import pytest

from judo.runtime.app import App
from judo.runtime.running import supervisor as exit_guard

SCRIPT = textwrap.dedent(
    """
    import sys, time
    import judo

    app = judo.App("cylinder_push", "mppi", gui=False, seed=0, num_workers=2)
    app.start()
    time.sleep(0.5)
    if sys.argv[1] == "raise":
        raise RuntimeError("the script failed")
    """
)


@pytest.mark.slow
def test_ten_scripts_that_end_without_stop_exit_without_a_crash(tmp_path):
    script = tmp_path / "no_stop.py"
    script.write_text(SCRIPT)
    runs = [
        subprocess.Popen(
            [sys.executable, str(script), mode],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for mode in ["end", "raise"] * 5
    ]
    results = [(run.args[-1], *run.communicate(timeout=120), run.returncode) for run in runs]
    for mode, _, err, code in results:
        if mode == "end":
            assert code == 0, err[-2000:]
        else:  # the script's own exception, reported as usual, and nothing after it
            assert code == 1 and err.rstrip().endswith("RuntimeError: the script failed"), err[
                -2000:
            ]


def test_the_hook_stops_every_started_app():
    apps = [App("cartpole", "ps", gui=False, seed=seed, num_workers=1) for seed in (0, 1)]
    for app in apps:
        app.start()
    assert all(app.running for app in apps)
    exit_guard.stop_running_apps()
    assert not any(app.running for app in apps)
    exit_guard.stop_running_apps()  # nothing left to stop
