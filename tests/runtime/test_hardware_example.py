"""examples/06_hardware_system.py: a user's own System drives the unchanged app, headless."""

import os
import subprocess
import sys
from pathlib import Path

import judo

ROOT = Path(__file__).resolve().parents[2]
SRC = str(Path(judo.__file__).resolve().parents[1])


def test_the_hardware_example_runs_headless_and_prints_a_summary():
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")]))}
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "06_hardware_system.py"), "--headless", "--duration", "1"],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "task: cartpole" in result.stdout and "sim time: 1.00 s" in result.stdout
    assert "control rate:" in result.stdout and "Traceback" not in result.stderr


def test_the_example_robot_reports_late_noisy_measurements():
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        example = __import__("06_hardware_system")
    finally:
        sys.path.remove(str(ROOT / "examples"))
    robot = example.LaggyNoisyCartpole(sensor_latency=0.05, noise_std=0.01, seed=1)
    truth = []
    for _ in range(20):
        robot.apply([0.5])
        robot.step()
        truth.append((robot.data.time, robot.data.qpos[0]))
    reading = robot.read_state()
    assert reading.time == robot.data.time  # stamped with the robot's clock...
    late_cart_x = [x for t, x in truth if t <= reading.time - 0.05 + 1e-9][-1]
    assert abs(reading.state[0] - late_cart_x) < 0.05  # ...but showing the cart as it was 50 ms ago
    assert reading.state[0] != late_cart_x  # with noise on it
    assert robot.data.qpos[0] > late_cart_x  # the pushed cart has moved on since
