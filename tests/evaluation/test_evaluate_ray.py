"""`python -m judo evaluate --workers 2` on a real local Ray with 2 CPUs: the seeds as Ray tasks
give the in-process run's episodes bit for bit, JSON and plot included; Ctrl-C cancels them and
exits 130."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import judo
from judo.evaluation.evaluate import main

# skipped without the extra; the local_ray fixture is in tests/conftest.py
pytest.importorskip("ray")

SRC = str(Path(judo.__file__).resolve().parents[1])
PATH = os.environ.get("PYTHONPATH")
CARTPOLE = [
    "--task",
    "cartpole",
    "--optimizer",
    "mppi",
    "--seeds",
    "2",
    "--duration",
    "1",
    "--latency-ms",
    "20",
]


def episodes_and_summary(path) -> tuple[list[dict], dict]:
    """The JSON report's episodes (without the wall-time median, which varies) and summary."""
    report = json.loads(path.read_text())
    episodes = [
        {k: v for k, v in episode.items() if k != "update_ms_median"}
        for episode in report["episodes"]
    ]
    return episodes, report["summary"]


@pytest.mark.slow
def table_rows(output: str) -> list[str]:
    """The metrics table's rows (rich's box lines) of evaluate's output, without what Ray forwards
    from its workers' logs around them."""
    return [line for line in output.splitlines() if "│" in line or "┃" in line]


def test_workers_give_the_in_process_episodes_bit_for_bit(tmp_path, capsys, local_ray):
    assert main([*CARTPOLE, "--json", str(tmp_path / "here.json")]) == 0
    here_table = table_rows(capsys.readouterr().out.split("control update")[0])
    plot = tmp_path / "seed0.html"
    assert (
        main(
            [*CARTPOLE, "--workers", "2", "--json", str(tmp_path / "ray.json"), "--plot", str(plot)]
        )
        == 0
    )
    ray_table = table_rows(capsys.readouterr().out.split("control update")[0])
    here, on_ray = (
        episodes_and_summary(tmp_path / "here.json"),
        episodes_and_summary(tmp_path / "ray.json"),
    )
    assert [episode["seed"] for episode in on_ray[0]] == [0, 1]
    assert on_ray == here  # every metric equal to full precision (JSON floats round-trip exactly)
    # two different episodes, not one twice
    assert on_ray[0][0]["metrics"] != on_ray[0][1]["metrics"]
    assert ray_table == here_table and any("balanced_fraction" in row for row in ray_table)
    # the log came back from the worker
    assert plot.stat().st_size > 1000 and "seed 0" in plot.read_text()


@pytest.mark.slow
def test_ctrl_c_cancels_the_episodes_and_exits_130():
    long_run = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--seeds",
        "4",
        "--duration",
        "3000",
        "--workers",
        "2",
    ]
    process = subprocess.Popen(
        [sys.executable, "-m", "judo", "evaluate", *long_run],
        env={
            **os.environ,
            "RAY_AUTH_MODE": "disabled",
            "PYTHONPATH": os.pathsep.join(filter(None, [SRC, PATH])),
        },
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        # a background shell ignores SIGINT
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(20)  # Ray started and both episodes running
    assert process.poll() is None
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err[-2000:]
    assert "interrupted" in err and "Traceback" not in err
