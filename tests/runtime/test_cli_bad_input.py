"""Bad values on the command line: a message naming the value and its valid range, exit status 2, no
traceback."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import judo
from judo.runtime import launch

SRC = str(Path(judo.__file__).resolve().parents[1])


def run_cli(argv: list[str], capsys) -> tuple[int, str]:
    """launch.main's exit status (tyro's own usage errors exit through SystemExit) and its
    stderr."""
    try:
        status = launch.main([*argv, "--headless"])
    except SystemExit as exit_:
        status = exit_.code
    return status, " ".join(capsys.readouterr().err.replace("│", " ").split())


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--seed", "-1"], "seed must be an integer from 0 to 2**63 - 1, got -1"),
        (
            ["--duration", "inf"],
            "duration must be a positive, finite number of seconds of sim time",
        ),
        (["--duration", "-1"], "duration must be a positive, finite number of seconds of sim time"),
        (
            ["--controller.horizon", "nan"],
            "ControllerConfig.horizon must be a finite number, got nan",
        ),
        (
            ["--controller.horizon", "inf"],
            "ControllerConfig.horizon must be a finite number, got inf",
        ),
        (["--controller.horizon", "-1"], "horizon must be above 0 and at most 60.0 s, got -1.0"),
        (
            ["--controller.horizon", "1e6"],
            "horizon must be above 0 and at most 60.0 s, got 1000000.0",
        ),
        (
            ["--controller.control-freq", "0"],
            "control_freq must be between 0.1 and 1000.0 Hz, got 0.0",
        ),
        (
            ["--controller.control-freq", "1e-9"],
            "control_freq must be between 0.1 and 1000.0 Hz, got 1e-09",
        ),
        (
            ["--controller.max-opt-iters", "1000000"],
            "max_opt_iters must be between 1 and 100, got 1000000",
        ),
        (
            ["--optimizer-config.num-rollouts", "10000000"],
            "num_rollouts must be between 1 and 1048576, got 10000000",
        ),
        (
            ["--optimizer-config.num-rollouts", "0"],
            "num_rollouts must be between 1 and 1048576, got 0",
        ),
        (
            ["--optimizer-config.num-nodes", "1000000"],
            "num_nodes must be between 1 and 100, got 1000000",
        ),
        (["--optimizer-config.sigma", "-1"], "sigma must be positive, got -1.0"),
        (["--optimizer-config.sigma", "nan"], "MPPIConfig.sigma must be a finite number, got nan"),
        (
            ["--task-config.w-centered", "inf"],
            "CartpoleConfig.w_centered must be a finite number, got inf",
        ),
        (["--task-config.goal-pos", "nan"], "goal_pos"),
    ],
)
def test_bad_values_exit_2_naming_the_value_and_its_range(capsys, argv, message):
    argv = ["--task", "cylinder_push", *argv] if "goal-pos" in argv[0] else argv
    status, err = run_cli(argv, capsys)
    assert status == 2
    assert message in err
    assert "Traceback" not in err


def run_judo(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
    }
    return subprocess.run(
        [sys.executable, "-m", "judo", *args],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
        cwd=cwd,
    )


def test_a_negative_seed_is_one_line_not_a_traceback(tmp_path):
    result = run_judo("--headless", "--seed", "-1", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr == "python -m judo: seed must be an integer from 0 to 2**63 - 1, got -1\n"


def test_a_config_whose_module_raises_names_the_file_entry_and_user_line_only(tmp_path):
    (tmp_path / "my_robot.py").write_text("import math\n\nLIMIT = math.sqrt(-1)\n")
    config = tmp_path / "judo.toml"
    config.write_text(
        '[custom_tasks.robot]\ntask = "my_robot.Robot"\nconfig = "my_robot.RobotConfig"\n'
    )
    result = run_judo("--config", str(config), "--headless", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith(
        f"python -m judo: {config}: [custom_tasks.robot]: importing module 'my_robot' "
        '(named by task = "my_robot.Robot") failed:\n'
    )
    assert f'File "{tmp_path / "my_robot.py"}", line 3, in <module>' in result.stderr
    assert "LIMIT = math.sqrt(-1)" in result.stderr
    assert result.stderr.endswith("ValueError: math domain error\n")
    assert "Traceback" not in result.stderr and "judo/" not in result.stderr.replace(
        str(tmp_path), ""
    )
