"""benchmarks/collect_throughput.py runs end to end on the smallest setting and prints its table."""

import pytest

from tests.test_benchmark_scripts import run_script


@pytest.mark.slow
def test_collect_throughput_prints_rates_scaling_and_file_size():
    pytest.importorskip("h5py")
    pytest.importorskip("ray")
    result = run_script(
        "collect_throughput.py", "--tasks", "cartpole", "--episodes", "2", "--duration", "0.2"
    )
    assert result.returncode == 0, result.stderr
    rows = [line for line in result.stdout.splitlines() if line.startswith("│ cartpole")]
    assert [row.split("│")[2].strip() for row in rows] == ["1", "2"]
    # KB per 1000 samples
    assert "1.00x" in rows[0] and all(float(row.split("│")[6]) > 0 for row in rows)
