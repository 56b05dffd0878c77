"""benchmarks/policy_controller.py runs end to end on the smallest settings and prints its table."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_policy_controller_prints_the_policies_inference_beside_the_mpc_update():
    pytest.importorskip("onnxruntime")
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "policy_controller.py"),
            "--tasks",
            "cartpole",
            "--optimizer",
            "ps",
        ]
        + ["--seeds", "1", "--duration", "0.2", "--hidden", "8"],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    rows = [line for line in result.stdout.splitlines() if "cartpole" in line]
    assert [row.split("│")[2].strip() for row in rows] == [
        "policy (linear)",
        "policy (mlp 8x8)",
        "ps",
    ]
    assert "µs" in rows[0] and "ms" in rows[2] and rows[2].split("│")[5].strip() == "1x"
