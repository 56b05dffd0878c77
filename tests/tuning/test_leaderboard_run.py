"""`python -m judo leaderboard` end to end: a tiny real leaderboard on a real local Ray and SQLite
file, and a real Ctrl-C mid-run after which the same command resumes without redoing a finished
trial."""

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from judo.cli_shared import apply_config_file
from judo.core.configuration import registry
from judo.core.configuration.registry import default_configs
from judo.tuning.leaderboard import main as leaderboard_main
from judo.tuning.leaderboard_protocol import load_protocol
from tests.tuning.test_tune_cli import stored_trials, trial_states_read_only, wait_for

optuna = pytest.importorskip("optuna")
pytest.importorskip("ray")  # the local_ray fixture is in tests/conftest.py

SHORT = """metric = "{metric}"
horizon = 0.5
num_rollouts = 8
duration = {duration}
tuning_seeds = 1
"""
"""A protocol of short episodes and little planning; the rest is the task's own."""


@pytest.fixture
def restored_overrides():
    """Undo the overrides a --config file sets in this process."""
    saved = dict(registry._OVERRIDES)
    yield
    registry._OVERRIDES.clear()
    registry._OVERRIDES.update(saved)


def protocols(folder: Path, duration: float) -> Path:
    """pendulum.toml and cartpole.toml of `duration` s episodes in `folder`."""
    folder.mkdir()
    (folder / "pendulum.toml").write_text(
        SHORT.format(metric="upright_fraction", duration=duration)
    )
    (folder / "cartpole.toml").write_text(SHORT.format(metric="mean_reward", duration=duration))
    return folder


def csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open() as file:
        return list(csv.DictReader(file))


@pytest.mark.slow
def test_a_tiny_leaderboard_writes_its_table_csv_plot_and_configs_that_load(
    local_ray, restored_overrides, tmp_path, capsys
):
    folder, out = protocols(tmp_path / "protocols", 0.5), tmp_path / "out"
    argv = [
        "--tasks",
        "pendulum",
        "cartpole",
        "--optimizers",
        "ps",
        "mppi",
        "--trials",
        "2",
        "--seeds",
        "2",
    ]
    assert leaderboard_main([*argv, "--protocols", str(folder), "--out", str(out)]) == 0
    printed = " ".join(capsys.readouterr().out.split())
    assert "pendulum upright_fraction ↑" in printed and "cartpole mean_reward ↑" in printed
    assert "shipped default (mppi)" in printed and "core-hours" in printed
    rows = csv_rows(out / "leaderboard.csv")
    assert [(row["task"], row["entry"]) for row in rows] == [
        ("pendulum", "ps"),
        ("pendulum", "mppi"),
        ("cartpole", "ps"),
        ("cartpole", "mppi"),
        ("pendulum", "shipped default (mppi)"),
        ("cartpole", "shipped default (mppi)"),
    ]
    for row in rows:
        assert row["n"] == "2" and row["failure"] == "" and float(row["ci95"]) >= 0
    for task in ("pendulum", "cartpole"):  # each task has a winner, and it has the task's best mean
        means = {row["entry"]: float(row["mean"]) for row in rows if row["task"] == task}
        won = [row["entry"] for row in rows if row["task"] == task and row["winner"] == "True"]
        assert won and all(means[entry] == max(means.values()) for entry in won)
    markdown = (out / "leaderboard.md").read_text()
    assert (
        markdown.startswith("| optimizer | pendulum upright_fraction ↑ | cartpole mean_reward ↑ |")
        and "**" in markdown
    )
    assert (out / "leaderboard.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # A tuned config is a --config file: the app and evaluate get the protocol's settings and the
    # best trial's.
    row = rows[3]
    apply_config_file(Path(row["config"]))
    configs = default_configs("cartpole", "mppi")
    best = dict(entry.split("=") for entry in row["params"].split())
    assert configs["optimizer"].num_rollouts == 8 and configs["controller"].control_freq == 50.0
    assert configs["optimizer"].sigma == pytest.approx(float(best["optimizer.sigma"]))
    assert configs["optimizer"].temperature == pytest.approx(float(best["optimizer.temperature"]))


def trials_by_study(storage: str, studies: list[str]) -> dict[str, list[tuple]]:
    """{study: [(number, state, value, start time, failure)]} of each study's stored trials."""
    return {
        study: [
            (
                trial.number,
                trial.state.name,
                trial.value,
                trial.datetime_start,
                trial.user_attrs.get("failure"),
            )
            for trial in stored_trials(storage, study)
        ]
        for study in studies
    }


@pytest.mark.slow
def test_ctrl_c_keeps_the_finished_trials_and_the_same_command_resumes_without_redoing_them(
    local_ray, tmp_path, capsys
):
    folder, out = protocols(tmp_path / "protocols", 1.0), tmp_path / "out"
    argv = [
        "--tasks",
        "pendulum",
        "--optimizers",
        "ps",
        "mppi",
        "--trials",
        "2",
        "--seeds",
        "2",
        "--workers",
        "1",
    ]
    argv += ["--protocols", str(folder), "--out", str(out)]
    digest = load_protocol("pendulum", folder).digest()
    database, studies = out / "leaderboard.db", [f"pendulum-ps-{digest}", f"pendulum-mppi-{digest}"]
    command = subprocess.Popen(
        [sys.executable, "-m", "judo", "leaderboard", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for(
            lambda: "COMPLETE" in trial_states_read_only(database, studies[0]),
            600,
            "a trial finished",
            command,
        )
        command.send_signal(signal.SIGINT)
        _, err = command.communicate(timeout=300)
    finally:
        command.kill()
    assert command.returncode == 130 and "Traceback" not in err
    assert "run the same command to resume" in err
    storage = f"sqlite:///{database}"
    before = trials_by_study(storage, studies)
    started = time.monotonic()
    assert leaderboard_main(argv) == 0  # the same command, in this process (on the module's Ray)
    after = trials_by_study(storage, studies)
    for study in studies:
        # the defaults may wait
        finished = [trial for trial in before[study] if trial[1] in ("COMPLETE", "FAIL")]
        # none redone, none changed
        assert [after[study][trial[0]] for trial in finished] == finished
        states = [trial[1] for trial in after[study]]
        assert states.count("COMPLETE") == 2
        # A trial the Ctrl-C stopped failed as interrupted, and does not count against the budget
        # of 2.
        assert all(trial[4] == "interrupted" for trial in after[study] if trial[1] == "FAIL")
        assert len(after[study]) == 2 + states.count("FAIL")
    assert any(trial[1] == "COMPLETE" for trial in before[studies[0]])
    runs = json.loads((out / "runs.json").read_text())
    assert [run["finished"] for run in runs] == [False, True] and runs[1][
        "wall_s"
    ] <= time.monotonic() - started + 1
    assert "all 2 runs into this folder" in " ".join(capsys.readouterr().out.split())
    assert [row["entry"] for row in csv_rows(out / "leaderboard.csv")] == [
        "ps",
        "mppi",
        "shipped default (mppi)",
    ]
