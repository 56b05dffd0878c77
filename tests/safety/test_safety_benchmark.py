"""benchmarks/safety_limits.py prints a row per case with and without limits, and no command outside them."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_rogue_case_serves_no_command_outside_the_limits():
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "safety_limits.py"), "--cases", "rogue", "--seeds", "1",
         "--duration", "0.5", "--no-cost"],
        capture_output=True, text=True, timeout=600, env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines() if line.startswith("rogue")]
    assert [row[1] for row in rows] == ["off", "on"]
    off, on = rows
    assert int(off[2]) > 0 and int(on[2]) == 0  # commands outside the effort cap: the Policy's, and none served
    assert int(on[5]) > 0  # the filter's hits
