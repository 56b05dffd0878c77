"""`evaluate --config` and `benchmark --config`: a task registered by a user's TOML file runs from
the command line."""

import json
import textwrap

import pytest

from judo.evaluation.benchmark import main as benchmark_main
from judo.evaluation.evaluate import main as evaluate_main
from tests.conftest import TINY_CARTPOLE_XML

USER_MODULE = '''
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import judo

@dataclass
class TinyBalanceConfig(judo.TaskConfig):
    w_upright: float = 1.0
    """Weight on the pole's height."""

class TinyBalance(judo.Task[TinyBalanceConfig]):
    """A task with no metrics hook: evaluate reports only mean_reward."""

    def __init__(self):
        super().__init__(Path(__file__).with_name("tiny.xml"))

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -config.w_upright * (1.0 - np.cos(states[..., 1])).sum(-1)
'''


@pytest.fixture
def user_config(tmp_path):
    """A --config file registering `tiny_balance_<n>` from a module beside it, with a horizon
    override."""
    module = f"tiny_balance_{tmp_path.name.replace('-', '_')}"
    (tmp_path / f"{module}.py").write_text(USER_MODULE)
    (tmp_path / "tiny.xml").write_text(TINY_CARTPOLE_XML)
    path = tmp_path / "judo.toml"
    path.write_text(
        textwrap.dedent(f"""
        [custom_tasks.{module}]
        task = "{module}.TinyBalance"
        config = "{module}.TinyBalanceConfig"
        [controller_config_overrides.{module}]
        horizon = 0.3
        [optimizer_config_overrides.{module}.all]
        num_rollouts = 8
        """)
    )
    return module, path


def test_evaluate_runs_a_task_registered_by_the_config_file(user_config, tmp_path):
    task, path = user_config
    report_path = tmp_path / "report.json"
    argv = [
        "--config",
        str(path),
        "--task",
        task,
        "--optimizer",
        "ps",
        "--seeds",
        "1",
        "--duration",
        "0.4",
    ]
    assert evaluate_main([*argv, "--num-workers", "1", "--json", str(report_path)]) == 0
    report = json.loads(report_path.read_text())
    assert report["task"] == task
    assert set(report["episodes"][0]["metrics"]) == {"mean_reward"}
    assert report["summary"]["mean_reward"]["mean"] <= 0.0


def test_benchmark_times_a_task_registered_by_the_config_file(user_config, tmp_path):
    task, path = user_config
    rows_path = tmp_path / "rows.json"
    argv = [
        "--config",
        str(path),
        "--tasks",
        task,
        "--optimizers",
        "ps",
        "--samples",
        "2",
        "--warmup",
        "0",
    ]
    assert benchmark_main([*argv, "--num-workers", "1", "--json", str(rows_path)]) == 0
    (row,) = json.loads(rows_path.read_text())
    # the file's override reached the controller
    assert (row["task"], row["num_rollouts"]) == (task, 8)


def test_a_missing_config_file_fails_with_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        evaluate_main(
            ["--config", str(tmp_path / "nope.toml"), "--task", "cartpole", "--optimizer", "ps"]
        )
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip() == (
        f"error: config file not found: {tmp_path / 'nope.toml'}"
    )
