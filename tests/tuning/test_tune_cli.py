"""`python -m judo tune` end to end on a real local Ray and a real SQLite file, and its failure
paths.

One Ray session (2 CPUs) serves every test of this module that needs one; tune uses a Ray the
process is already connected to, so it starts in one place only.
"""

import contextlib
import csv
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from judo.core.configuration import registry
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import make_config
from judo.evaluation.evaluate import main as evaluate_main
from judo.optimizers.ps import PredictiveSamplingConfig
from judo.tuning.heartbeat import DEAD_PROCESS, STALE_AFTER_S
from judo.tuning.tune import main as tune_main

optuna = pytest.importorskip("optuna")
# skipped without the extra; the local_ray fixture is in tests/conftest.py
pytest.importorskip("ray")

TINY_STUDY = [
    "--task", "cartpole", "--optimizer", "ps", "--seeds", "1", "--duration", "2", "--workers", "2",
    "--params", "optimizer.sigma", "controller.horizon=0.3:1.0", "--fix", "optimizer.num_rollouts=16",  # noqa: E501
    "--latency-ms", "0",
]  # fmt: skip


@pytest.fixture
def restored_overrides():
    """Undo the overrides a --config file sets in this process."""
    saved = dict(registry._OVERRIDES)
    yield
    registry._OVERRIDES.clear()
    registry._OVERRIDES.update(saved)


def stored_trials(storage: str, name: str) -> list:
    return optuna.load_study(study_name=name, storage=storage).get_trials(deepcopy=False)


def trial_states_read_only(path: Path, name: str) -> list[str]:
    """The states of study `name`'s trials in the SQLite file at `path`, read as a running tune
    writes it: plain read-only SQL, since opening it through optuna would create the schema the tune
    is creating (the two race), and [] until the file, its tables and the study exist or while the
    tune holds the file's lock."""
    query = (
        "SELECT trials.state FROM trials JOIN studies ON trials.study_id = studies.study_id "
        "WHERE studies.study_name = ? ORDER BY trials.number"
    )
    if not path.exists():
        return []
    try:
        with contextlib.closing(
            sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=1.0)
        ) as connection:
            return [state for (state,) in connection.execute(query, (name,)).fetchall()]
    except sqlite3.Error:
        return []


def heartbeat_age_read_only(path: Path, trial_number: int) -> float | None:
    """Seconds since trial `trial_number`'s last heartbeat by SQLite's clock (the one Optuna stamps
    them with), read as `trial_states_read_only` reads; None while it has none (or the file is
    locked)."""
    query = (
        "SELECT (julianday('now') - julianday(trial_heartbeats.heartbeat)) * 86400 FROM "
        "trial_heartbeats "
        "JOIN trials ON trial_heartbeats.trial_id = trials.trial_id WHERE trials.number = ?"
    )
    if not path.exists():
        return None
    try:
        with contextlib.closing(
            sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=1.0)
        ) as connection:
            row = connection.execute(query, (trial_number,)).fetchone()
    except sqlite3.Error:
        return None
    return None if row is None else float(row[0])


def wait_for(condition, seconds: float, what: str, process: subprocess.Popen | None = None) -> None:
    """Poll `condition()` every 0.5 s until it holds; fail naming `what` after `seconds` or when
    `process` ends."""
    deadline = time.monotonic() + seconds
    while not condition():
        assert process is None or process.poll() is None, (
            f"tune ended before {what}: {process.communicate()}"
        )
        assert time.monotonic() < deadline, f"not {what} in {seconds:g} s"
        time.sleep(0.5)


@pytest.mark.slow
def test_a_tiny_study_is_stored_resumed_and_its_best_file_loads(
    local_ray, restored_overrides, tmp_path, capsys
):
    storage, out = f"sqlite:///{tmp_path / 'tune.db'}", tmp_path / "out"
    argv = [*TINY_STUDY, "--storage", storage, "--study", "tiny", "--out", str(out)]
    assert tune_main([*argv, "--trials", "3"]) == 0
    first = stored_trials(storage, "tiny")
    assert [trial.state.name for trial in first] == ["COMPLETE"] * 3
    assert all(set(trial.params) == {"optimizer.sigma", "controller.horizon"} for trial in first)
    assert all(
        trial.user_attrs["plan_ms"] > 0 and "swung_up" in trial.user_attrs["metrics"]
        for trial in first
    )
    for name in (
        "trials.csv",
        "best.toml",
        "summary.json",
        "history.html",
        "history.png",
        "best_episode.html",
    ):
        assert (out / name).is_file(), name
    assert len((out / "trials.csv").read_text().splitlines()) == 1 + 3
    defaults = (
        make_config(PredictiveSamplingConfig, "cartpole").sigma,
        make_config(ControllerConfig, "cartpole").horizon,
    )
    assert first[0].user_attrs["baseline"] and not any(
        trial.user_attrs.get("baseline") for trial in first[1:]
    )
    assert (first[0].params["optimizer.sigma"], first[0].params["controller.horizon"]) == defaults
    printed = capsys.readouterr().out
    assert (
        "top trials of tiny: mean_reward (maximize)" in printed
        and "3 completed, 0 failed" in printed
    )
    assert f"defaults (trial 0): mean_reward {first[0].value:.4g}" in printed
    assert json.loads((out / "summary.json").read_text())["defaults"]["number"] == 0

    assert tune_main([*argv, "--trials", "4"]) == 0  # resumes: one more trial
    resumed = stored_trials(storage, "tiny")
    assert [trial.state.name for trial in resumed] == ["COMPLETE"] * 4
    assert [trial.params for trial in resumed[:3]] == [trial.params for trial in first]
    # the console wraps
    assert "resuming with 3 finished trials" in " ".join(capsys.readouterr().out.split())

    best = max(resumed, key=lambda trial: trial.value)
    best_file = out / "best.toml"
    text = best_file.read_text()
    assert (
        f"trial {best.number}," in text
        and "# Found by: python -m judo tune --task cartpole --optimizer ps" in text
    )
    assert evaluate_main(["--config", str(best_file), "--task", "cartpole", "--optimizer", "ps", "--seeds", "1",  # noqa: E501
                          "--duration", "0.2", "--num-workers", "1"]) == 0  # fmt: skip
    loaded = make_config(PredictiveSamplingConfig, "cartpole")
    assert (loaded.sigma, loaded.num_rollouts) == (best.params["optimizer.sigma"], 16)


@pytest.mark.slow
def test_a_tiny_multi_condition_study_records_every_condition(
    local_ray, restored_overrides, tmp_path
):
    out = tmp_path / "out"
    argv = [*TINY_STUDY[:-2], "--conditions", "control_freq=20,50", "--aggregate", "worst", "--metric",  # noqa: E501
            "balanced_fraction", "--trials", "2", "--duration", "1", "--out", str(out)]  # fmt: skip
    assert tune_main(argv) == 0
    trials = stored_trials(f"sqlite:///{out / 'study.db'}", "cartpole-ps-balanced_fraction")
    assert [trial.state.name for trial in trials] == ["COMPLETE"] * 2
    labels = ["control_freq=20", "control_freq=50"]
    for trial in trials:
        assert list(trial.user_attrs["conditions"]) == labels
        assert trial.value == min(trial.user_attrs["conditions"].values())
    header, *rows = (out / "trials.csv").read_text().splitlines()
    columns = header.split(",")
    assert (
        columns[2:5] == ["value", *(f"balanced_fraction@{label}" for label in labels)]
        and len(rows) == 2
    )
    summary = json.loads((out / "summary.json").read_text())
    assert (
        summary["conditions"] == "control_freq=20; control_freq=50"
        and summary["aggregate"] == "worst"
    )
    assert list(summary["best"]["conditions"]) == labels
    assert (out / "conditions.html").is_file() and (out / "conditions.png").is_file()
    assert "# Per condition: control_freq=20: " in (out / "best.toml").read_text()
    assert evaluate_main(["--config", str(out / "best.toml"), "--task", "cartpole", "--optimizer", "ps", "--seeds",  # noqa: E501
                          "1", "--duration", "0.2", "--num-workers", "1"]) == 0  # fmt: skip


def run_failing(argv: list[str], capsys) -> str:
    """tune's stderr for `argv`, which must exit with status 2 and no traceback."""
    with pytest.raises(SystemExit) as exit_info:
        tune_main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err.strip()


def test_a_bad_storage_url_says_what_is_expected(tmp_path, capsys):
    err = run_failing(
        [*TINY_STUDY, "--trials", "1", "--storage", "nosuchdb://x/y", "--out", str(tmp_path)],
        capsys,
    )
    assert err.startswith("error: cannot open the study storage 'nosuchdb://x/y': ")
    assert err.endswith(
        "Expected an Optuna RDB URL such as sqlite:///judo-tune.db or "
        "postgresql://user:password@host/database"
    )


def test_an_unreachable_address_says_how_to_start_a_cluster(tmp_path, capsys):
    argv = [*TINY_STUDY, "--trials", "1", "--address", "ray://127.0.0.1:1", "--out", str(tmp_path)]
    err = run_failing(argv, capsys)
    assert err.startswith("error: cannot reach a Ray cluster at 'ray://127.0.0.1:1': ")
    assert "`ray start --head`" in err and "--address ray://HEAD:10001" in err


def test_an_unknown_metric_lists_the_tasks_metrics(tmp_path, capsys):
    err = run_failing([*TINY_STUDY, "--metric", "upright", "--out", str(tmp_path)], capsys)
    assert (
        err == "error: task 'cartpole' reports no metric 'upright'; its metrics are: "
        "balanced_fraction, swung_up, mean_reward"
    )


def test_an_unknown_parameter_lists_the_valid_ones(tmp_path, capsys):
    err = run_failing(
        [
            "--task",
            "cartpole",
            "--optimizer",
            "ps",
            "--params",
            "optimizer.sigam",
            "--out",
            str(tmp_path),
        ],
        capsys,
    )
    assert err.startswith("error: unknown parameter 'optimizer.sigam'") and "optimizer.sigma" in err


def test_without_the_extra_tune_names_it(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "optuna", None)
    err = run_failing([*TINY_STUDY, "--out", str(tmp_path)], capsys)
    assert err == (
        "error: python -m judo tune needs the optional extra judo-mpc[tune], which is not "
        "installed "
        "(no module 'optuna'); install it with: pip install -e \".[tune]\" (from a checkout) or "
        'pip install "judo-mpc[tune]"'
    )


def test_importing_judo_and_the_tune_command_imports_neither_optuna_nor_ray():
    code = "import sys, judo, judo.tuning.tune; print(sorted({'optuna', 'ray'} & set(sys.modules)))"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "[]"


def tune_argv(tmp_path: Path, study: str, trials: int, duration: float) -> list[str]:
    """`python -m judo tune` of cartpole x ps, one trial at a time of one seed, stored in
    tmp_path/tune.db."""
    return [
        sys.executable, "-m", "judo", "tune", "--task", "cartpole", "--optimizer", "ps", "--seeds", "1",  # noqa: E501
        "--duration", f"{duration:g}", "--workers", "1", "--params", "optimizer.sigma", "--trials", str(trials),  # noqa: E501
        "--storage", f"sqlite:///{tmp_path / 'tune.db'}", "--study", study, "--out", str(tmp_path / "out"),  # noqa: E501
        "--latency-ms", "0",
    ]  # fmt: skip


@pytest.mark.slow
def test_ctrl_c_stops_a_running_tune_at_once_and_keeps_every_finished_trial(tmp_path):
    path = tmp_path / "tune.db"
    tune = subprocess.Popen(
        tune_argv(tmp_path, "stopped", 5, 5),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )

    def second_trial_running() -> bool:
        states = trial_states_read_only(path, "stopped")
        return states.count("COMPLETE") == 1 and "RUNNING" in states

    try:
        wait_for(second_trial_running, 600, "a second trial running", tune)
        tune.send_signal(signal.SIGINT)
        started = time.monotonic()
        _, err = tune.communicate(timeout=300)
        stopped_after = time.monotonic() - started
    finally:
        tune.kill()
    assert tune.returncode == 130 and "Traceback" not in err
    assert "run the same command to resume" in err
    trials = stored_trials(f"sqlite:///{path}", "stopped")
    assert [trial.state.name for trial in trials] == ["COMPLETE", "FAIL"]
    # At once: trial 1 is failed as interrupted, not run to its end; and the stop (Ray's shutdown
    # included) is bounded, generously for a loaded machine.
    assert trials[0].user_attrs["baseline"] and trials[1].user_attrs["failure"] == "interrupted"
    assert stopped_after < 60, f"tune took {stopped_after:.1f} s to stop"


@pytest.mark.slow
def test_a_trial_left_running_by_a_killed_tune_is_failed_on_resume_and_named(tmp_path):
    path = tmp_path / "tune.db"
    tune = subprocess.Popen(
        tune_argv(tmp_path, "killed", 1, 60),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        # its own process group, so that the Ray it started can be cleared up after
        start_new_session=True,
    )

    def beating() -> bool:
        return (
            trial_states_read_only(path, "killed") == ["RUNNING"]
            and heartbeat_age_read_only(path, 0) is not None
        )

    def stale() -> bool:
        return (heartbeat_age_read_only(path, 0) or 0.0) > STALE_AFTER_S + 1

    try:
        wait_for(beating, 600, "trial 0 running with a heartbeat", tune)
        tune.send_signal(signal.SIGKILL)
        tune.wait(timeout=60)
        wait_for(stale, STALE_AFTER_S + 120, "trial 0's heartbeat stale")
        assert trial_states_read_only(path, "killed") == ["RUNNING"]  # nothing else fails it
        # The same study resumed (a shorter --duration, which is not part of a study's identity),
        # to 2 trials.
        resumed = subprocess.run(
            tune_argv(tmp_path, "killed", 2, 1), capture_output=True, text=True, timeout=600
        )
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(tune.pid, signal.SIGKILL)
    assert resumed.returncode == 0, resumed.stderr
    printed = " ".join(resumed.stdout.split())  # the console wraps
    assert "resumed: trial 0 was left RUNNING by a process that died; marked FAIL" in printed
    assert "resuming with 1 finished trials" in printed
    with (tmp_path / "out" / "trials.csv").open() as file:
        rows = list(csv.DictReader(file))
    assert [(row["number"], row["state"]) for row in rows] == [("0", "FAIL"), ("1", "COMPLETE")]
    assert rows[0]["failure"] == DEAD_PROCESS and rows[1]["failure"] == ""
