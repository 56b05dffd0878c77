"""`python -m judo`: options from the configs, unknown names, the --duration summary, command
dispatch."""

import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import judo.__main__
from judo import get_registered_optimizers, get_registered_tasks
from judo.core.configuration.registry import default_configs
from judo.runtime import launch

SRC = str(Path(judo.__main__.__file__).parents[1])
CONFIG_FILE = Path(__file__).resolve().parents[2] / "examples" / "04_config_file" / "judo.toml"


def test_unknown_task_exits_2_with_the_valid_names_and_no_traceback():
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
    }
    result = subprocess.run(
        [sys.executable, "-m", "judo", "--task", "no_such_task"],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert result.returncode == 2
    prefix = "python -m judo: unknown task 'no_such_task'; valid tasks are: "
    assert result.stderr.startswith(prefix) and result.stderr.count("\n") == 1  # one line
    listed = result.stderr.strip().removeprefix(prefix).split(", ")
    assert {"cartpole", "cylinder_push"} <= set(listed) and listed == sorted(listed)
    assert "Traceback" not in result.stdout + result.stderr


def test_unknown_optimizer_exits_2_with_the_valid_names(capsys):
    assert launch.main(["--optimizer=no_such_optimizer"]) == 2
    err = capsys.readouterr().err
    optimizers = ", ".join(sorted(get_registered_optimizers()))
    assert err.strip() == (
        f"python -m judo: unknown optimizer 'no_such_optimizer'; valid optimizers are: {optimizers}"
    )


def test_overrides_reach_the_chosen_configs():
    argv = [
        "--task", "cylinder_push", "--optimizer", "cem", "--headless", "--duration", "3", "--port", "9000",  # noqa: E501
        "--controller.horizon", "0.5", "--controller.spline-order", "cubic",
        "--optimizer-config.sigma-max", "0.3", "--optimizer-config.num-rollouts", "16",
        "--task-config.goal-pos", "0.25", "-0.5", "--task-config.w-cart-position", "2",
    ]  # fmt: skip
    options, configs = launch.parse(argv, default_configs("cylinder_push", "cem"))
    assert (options.task, options.optimizer, options.headless, options.duration, options.port) == (
        "cylinder_push", "cem", True, 3.0, 9000,
    )  # fmt: skip
    assert (configs["controller"].horizon, configs["controller"].spline_order) == (0.5, "cubic")
    assert (configs["optimizer"].sigma_max, configs["optimizer"].num_rollouts) == (0.3, 16)
    assert configs["optimizer"].sigma_min == 0.05  # cylinder_push's registered default
    np.testing.assert_array_equal(configs["task"].goal_pos, [0.25, -0.5])
    assert configs["task"].w_cart_position == 2.0


def test_a_config_file_names_the_task_and_sets_defaults_that_options_still_override(capsys):
    with pytest.raises(SystemExit):
        launch.main(["--config", str(CONFIG_FILE), "--controller.max-opt-iters", "2", "--help"])
    text = capsys.readouterr().out
    assert "Balance-task weights." in text  # the file's task, registered from its module
    assert "Planning horizon in seconds. (default: 0.6)" in text  # the file's override
    task, optimizer, *_ = launch._peek(["--config", str(CONFIG_FILE), "--task", "cartpole"])
    assert (task, optimizer) == ("cartpole", "cooling_mppi")


def test_a_missing_config_file_exits_2_with_its_name(capsys):
    assert launch.main(["--config", "no/such/judo.toml"]) == 2
    assert capsys.readouterr().err.strip() == (
        "python -m judo: config file not found: no/such/judo.toml"
    )


def test_help_documents_the_fields_of_the_chosen_configs(capsys):
    with pytest.raises(SystemExit) as exit_info:
        launch.main(["--task", "cylinder_push", "--optimizer", "cem", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for option in (
        "--headless",
        "--duration",
        "--controller.horizon",
        "--optimizer-config.num-elites",
    ):
        assert option in text
    assert (
        "--task-config.goal-pos" in text and "Goal position (m) of the cart on the table." in text
    )
    tasks, optimizers = (
        ", ".join(sorted(get_registered_tasks())),
        ", ".join(sorted(get_registered_optimizers())),
    )
    assert f"Tasks: {tasks}. Optimizers: {optimizers}." in " ".join(text.split())
    # every command
    for command in ("benchmark ...", "evaluate ...", "tune ...", "collect ...", "replay FILE.h5"):
        assert f"`python -m judo {command}`" in " ".join(text.split()), command


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--task", "cylinder_push", "--task-config.goal-pos", "1"],
            "CylinderPushConfig.goal_pos expects 2 numbers",
        ),
        (
            ["--controller.horizon", "0.001"],
            r"horizon (0.001 s) is shorter "
            r"than one timestep (0.01 s)",
        ),
    ],
)
def test_invalid_overrides_exit_2_with_the_reason(capsys, argv, message):
    assert launch.main([*argv, "--headless"]) == 2
    assert message in capsys.readouterr().err


def test_duration_runs_headless_and_prints_the_summary(capsys):
    status = launch.main(
        ["--headless", "--duration", "0.5", "--seed", "0", "--optimizer-config.num-rollouts", "8"]
    )
    assert status == 0
    out = capsys.readouterr().out
    for label in (
        "task: cartpole",
        "optimizer: mppi",
        "control rate:",
        "plan time: mean",
        "real-time factor:",
    ):
        assert label in out
    assert "final reward:" in out and "sim time: 0.50 s" in out


def test_a_proposal_policy_plans_with_the_app_and_one_for_another_task_exits_2(capsys):
    pytest.importorskip("onnxruntime")
    policy = str(
        Path(launch.__file__).parents[1] / "tasks" / "models" / "policies" / "pendulum_chunk.onnx"
    )
    argv = ["--headless", "--duration", "0.5", "--seed", "0", "--proposal-policy", policy]
    status = launch.main(
        [*argv, "--task", "pendulum", "--optimizer", "ps", "--controller.policy-samples", "4"]
    )
    assert status == 0 and "task: pendulum" in capsys.readouterr().out
    assert launch.main([*argv, "--task", "cartpole"]) == 2
    assert "was made for task 'pendulum', not 'cartpole'" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["benchmark", "evaluate"])
def test_benchmark_and_evaluate_are_dispatched_with_the_remaining_arguments(monkeypatch, command):
    received = []
    module = types.ModuleType(f"judo.evaluation.{command}")
    module.main = lambda argv: received.append(argv) or 7  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "judo.evaluation", types.ModuleType("judo.evaluation"))
    monkeypatch.setitem(sys.modules, f"judo.evaluation.{command}", module)
    assert judo.__main__.main([command, "--task", "cartpole"]) == 7
    assert received == [["--task", "cartpole"]]
