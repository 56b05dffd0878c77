"""`evaluate` and `benchmark` take any ControllerConfig field as --controller.FIELD, over the task's
defaults."""

import json

import pytest

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import lookup_task, make_config
from judo.evaluation import benchmark, evaluate, shared_options
from judo.optimizers.ps import PredictiveSamplingConfig

TINY = [
    "--task",
    "cartpole",
    "--optimizer",
    "ps",
    "--seeds",
    "1",
    "--duration",
    "0.3",
    "--num-workers",
    "1",
]


def test_evaluate_plans_under_the_randomization_given(tmp_path, capsys):
    path = tmp_path / "eval.json"
    argv = [
        *TINY,
        "--controller.num-randomizations",
        "3",
        "--controller.risk",
        "cvar",
        "--json",
        str(path),
    ]
    assert evaluate.main(argv) == 0
    report = json.loads(path.read_text())
    assert report["controller"] == {"num_randomizations": 3, "risk": "cvar"}
    assert report["episodes"][0]["num_updates"] == round(
        0.3 * make_config(ControllerConfig, "cartpole").control_freq
    )
    assert "num_randomizations=3, risk=cvar" in capsys.readouterr().out


def test_fields_not_given_keep_the_task_defaults():
    args = evaluate.EvaluateArgs(task="cartpole", optimizer="ps")
    args.controller.num_randomizations = 2
    config = shared_options.controller_config("cartpole", args.controller)
    task_default = make_config(ControllerConfig, "cartpole")
    assert config.num_randomizations == 2 and config.horizon == task_default.horizon
    # cartpole's override, not the class default
    assert config.spline_order == task_default.spline_order == "cubic"


def test_benchmark_accounts_the_randomizations_in_the_floor(tmp_path, capsys):
    path = tmp_path / "bench.json"
    argv = [
        "--tasks",
        "cartpole",
        "--optimizers",
        "ps",
        "--samples",
        "2",
        "--warmup",
        "1",
        "--num-workers",
        "1",
    ]
    assert benchmark.main([*argv, "--controller.num-randomizations", "2", "--json", str(path)]) == 0
    (row,) = json.loads(path.read_text())
    sizes = (
        make_config(ControllerConfig, "cartpole"),
        make_config(PredictiveSamplingConfig, "cartpole"),
    )
    steps = round(sizes[0].horizon / lookup_task("cartpole")[0]().dt)
    assert row["num_randomizations"] == 2 and row["num_rollouts"] == sizes[1].num_rollouts
    assert f"{sizes[1].num_rollouts} x 2 x {steps}" in capsys.readouterr().out


@pytest.mark.parametrize("command", [evaluate.main, benchmark.main])
def test_a_bad_controller_value_fails_before_running(command, capsys):
    names = TINY[:4] if command is evaluate.main else ["--tasks", "cartpole", "--optimizers", "ps"]
    with pytest.raises(SystemExit) as exited:
        command([*names, "--controller.cvar-alpha", "1.5"])
    assert exited.value.code == 2
    assert "error: cvar_alpha must be in (0, 1], got 1.5" in capsys.readouterr().err
