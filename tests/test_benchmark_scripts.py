"""The benchmark scripts run end to end on the smallest settings and print their tables."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / args[0]), *args[1:]],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        cwd=ROOT,
    )


def test_task_suite_prints_a_markdown_table_per_task(tmp_path):
    out = tmp_path / "suite.md"
    small = ["--seeds", "1", "--duration", "0.3", "--timing-samples", "2", "--markdown", str(out)]
    result = run_script("task_suite.py", "--tasks", "cartpole", "particle", "--optimizers", "ps", *small)
    assert result.returncode == 0, result.stderr
    assert "### cartpole (1 seed x 0.3 s, no latency)" in result.stdout
    assert "| optimizer | update ms | rollout floor ms | overhead | balanced_fraction | swung_up |" in result.stdout
    assert "### particle" in result.stdout and "goals_per_minute" in result.stdout
    assert out.read_text().count("| ps | ") == 2


def test_task_suite_names_the_valid_choices_for_an_unknown_task():
    result = run_script("task_suite.py", "--tasks", "cartpol")
    assert result.returncode == 2
    assert "cartpol" in result.stderr and "cartpole" in result.stderr


def test_robust_planning_prints_a_row_per_setting():
    small = ["--seeds", "1", "--duration", "0.2", "--num-workers", "1", "--optimizers", "cem"]
    result = run_script(
        "robust_planning.py", "--task", "leap_cube", *small, "--randomizations", "1", "2", "--risks", "cvar"
    )
    assert result.returncode == 0, result.stderr
    assert "### leap_cube on a mismatched plant (leap_cube_plant.xml), 1 seed(s) from 0 x 0.2 s" in result.stdout
    assert "| cem | 1 | - | 0 | 0 |" in result.stdout and "| cem | 2 | cvar 0.5 | 0 | 0 |" in result.stdout


def test_randomized_overhead_prints_the_ratio_per_r():
    small = ["--task", "cartpole", "--optimizer", "ps", "--samples", "2", "--warmup", "1", "--num-workers", "1"]
    result = run_script("randomized_overhead.py", *small, "--randomizations", "1", "3")
    assert result.returncode == 0, result.stderr
    assert "| 1 | 32 x 1 x 100 |" in result.stdout and "| 3 | 32 x 3 x 100 |" in result.stdout
