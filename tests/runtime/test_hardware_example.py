"""examples/06_hardware_system.py: a user's own encoders-only System drives the unchanged app
through the EKF."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import judo

ROOT = Path(__file__).resolve().parents[2]
SRC = str(Path(judo.__file__).resolve().parents[1])


def test_the_hardware_example_runs_headless_and_prints_a_summary():
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
    }
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "06_hardware_system.py"),
            "--headless",
            "--duration",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "estimator: ekf" in result.stdout  # a sensors-only reading gets the EKF by default
    assert "task: cartpole" in result.stdout and "sim time: 1.00 s" in result.stdout
    assert "control rate:" in result.stdout and "Traceback" not in result.stderr


def example_module():
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        return __import__("06_hardware_system")
    finally:
        sys.path.remove(str(ROOT / "examples"))


def test_the_example_robot_reports_only_late_noisy_encoders_stamped_when_taken():
    robot = example_module().LaggyNoisyCartpole(
        sensor_latency=0.05, noise_std=0.01, sensor_rate=100.0, seed=1
    )
    truth = {}
    for _ in range(30):
        robot.apply([0.5])
        robot.step()
        truth[round(robot.data.time, 6)] = robot.data.qpos.copy()
    reading = robot.read_state()
    assert reading.state is None and reading.sensors.shape == (2,)  # encoders only, no velocities
    # stamped with when it was taken, 50 ms ago
    assert abs(reading.time - (robot.time - 0.05)) < 0.011
    taken = truth[round(reading.time, 6)]
    assert np.allclose(reading.sensors, taken, atol=0.05)  # the joints as they were then...
    assert not np.array_equal(reading.sensors, taken)  # ...with noise on them
    assert robot.data.qpos[0] > taken[0]  # the pushed cart has moved on since


def test_the_ekf_tracks_the_example_robot_through_the_closed_loop():
    from judo.core.configuration.registry import make_controller, make_estimator
    from judo.loop.closed_loop import ClosedLoop

    robot = example_module().LaggyNoisyCartpole(seed=2)
    controller = make_controller("cartpole", "mppi", num_workers=1, seed=0)
    try:
        loop = ClosedLoop(
            controller,
            robot,
            estimator=make_estimator("ekf", controller.task, task_name="cartpole"),
        )
        errors = []
        for _ in range(150):  # 1.5 s of a swing-up
            record = loop.step()
            truth = np.concatenate([robot.data.qpos, robot.data.qvel])
            errors.append(np.abs(record.estimate - truth))
        late = np.array(errors[50:])
        assert late[:, :2].max() < 0.1  # positions (m, rad), from noisy encoders 20 ms late
        # velocities it never measures (m/s, rad/s)
        assert np.median(late[:, 2:], axis=0).max() < 0.5
    finally:
        controller.close()
