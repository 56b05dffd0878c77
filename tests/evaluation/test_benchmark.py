import json

import numpy as np
import pytest

from judo.core.configuration.registry import get_registered_tasks
from judo.evaluation.benchmark import main
from judo.evaluation.timing import UpdateTiming, time_pair


def test_benchmark_writes_one_row_per_pair(tmp_path, capsys):
    path = tmp_path / "bench.json"
    argv = ["--tasks", "cartpole", "cylinder_push", "--optimizers", "ps", "mppi"]
    assert (
        main([*argv, "--samples", "3", "--warmup", "1", "--num-workers", "1", "--json", str(path)])
        == 0
    )
    rows = json.loads(path.read_text())
    assert [(row["task"], row["optimizer"]) for row in rows] == [
        ("cartpole", "ps"),
        ("cartpole", "mppi"),
        ("cylinder_push", "ps"),
        ("cylinder_push", "mppi"),
    ]
    expected_keys = {
        "task",
        "optimizer",
        "num_rollouts",
        "T",
        "median_ms",
        "mean_ms",
        "std_ms",
        "raw_rollout_ms",
    }
    for row in rows:
        assert expected_keys <= row.keys()
        assert row["median_ms"] > 0 and row["raw_rollout_ms"] > 0 and row["std_ms"] >= 0
        assert row["min_ms"] <= row["median_ms"] <= row["max_ms"]
        assert row["num_workers"] == 1
    # T is the horizon over the timestep: cartpole plans 1.0 s at 0.01 s, cylinder_push 1 s at 0.02
    # s
    assert [row["T"] for row in rows] == [100, 100, 50, 50]
    out = capsys.readouterr().out
    assert "cartpole: control update time (ms), 1 rollout workers" in out
    assert "median (IQR)" in out and "raw rollout" in out and "overhead" in out
    for row in rows:  # what an update costs beyond its physics
        assert row["fixed_cost_us"] == pytest.approx(1e3 * (row["median_ms"] - row["floor_ms"]))


def test_timing_uses_the_sizes_asked_for():
    timing = time_pair("cartpole", "cem", 2, warmup=0, num_rollouts=16, horizon=0.5, num_workers=1)
    assert (timing.num_rollouts, timing.num_steps) == (16, 50)
    assert timing.update_ms.shape == timing.raw_rollout_ms.shape == (2,)
    assert timing.overhead_ratio() > 0


def test_an_unknown_task_lists_the_valid_ones(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--tasks", "cartpol"])
    assert exit_info.value.code == 2
    valid = ", ".join(sorted(get_registered_tasks()))
    assert capsys.readouterr().err == f"error: unknown task 'cartpol'; valid tasks are: {valid}\n"


def test_an_unknown_optimizer_is_refused_before_any_timing(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--optimizers", "ps", "sgd", "--samples", "100000"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith(
        "error: unknown optimizer 'sgd'; valid optimizers are: "
    )


def test_samples_must_be_positive(capsys):
    with pytest.raises(SystemExit):
        main(["--samples", "0"])
    assert capsys.readouterr().err == (
        "error: --samples must be an integer from 1 to 100000, got 0\n"
    )


def test_help_names_the_flags_and_the_choices(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for flag in ("--tasks", "--optimizers", "--samples", "--num-workers", "--json"):
        assert flag in out
    assert "cartpole" in out and "mppi" in out


def test_the_rollout_floor_counts_one_batch_per_iteration():
    timing = UpdateTiming("t", "o", 8, 10, 1, 3, np.array([9.0, 9.0]), np.array([2.0, 4.0]))
    assert timing.floor_ms() == 3 * 3.0
    # the update against the same work: three raw rollouts
    assert timing.overhead_ratio() == 9.0 / 9.0
    assert timing.row()["floor_ms"] == 9.0
    assert timing.fixed_cost_us() == 0.0


def test_cpu_time_needs_one_worker_and_names_the_clock(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--tasks", "pendulum", "--cpu-time", "--num-workers", "2"])
    assert exit_info.value.code == 2
    expected = (
        "--cpu-time needs --num-workers 1, so that every rollout runs on the timed thread; got "
        "--num-workers 2"
    )
    assert capsys.readouterr().err == f"error: {expected}\n"
    argv = [
        "--tasks",
        "pendulum",
        "--optimizers",
        "ps",
        "--samples",
        "2",
        "--warmup",
        "0",
        "--num-workers",
        "1",
    ]
    assert main([*argv, "--cpu-time"]) == 0
    assert (
        "pendulum: control update time (ms of thread CPU time), 1 rollout workers"
        in capsys.readouterr().out
    )
