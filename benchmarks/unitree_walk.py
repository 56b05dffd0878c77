"""The Go2 over Unitree's own wire on loopback: judo's robot process (`python -m judo plant --task T
--protocol unitree`, the robot's PD at 500 Hz, publishing only rt/lowstate) and the app
(`python -m judo --task T --system unitree --headless`), planning from the estimator's base made of
the IMU, the encoders and the foot forces.

The robot process logs its true base once a second of its simulation (height, tilt, position on the
floor, heading), which no message carries; from those lines this prints, per run: when the base
first stood (above 0.8 x 0.30 m, under 30 degrees of tilt), the share of reports standing, falls
(down again after standing), and for go2_walk the mean speed in the base's heading frame over the
seconds after the first three, its error against the command (m/s) and the yaw rate (rad/s). The
robot's soft start and the processes' start-up take the first second or two of the robot's clock.

    PYTHONPATH=src python benchmarks/unitree_walk.py [--task go2_walk] [--estimator ekf] [--seeds 2]

Needs pip install -e ".[unitree]". The app and the robot share the machine's cores: on a loaded
machine the robot's clock runs slow and the planner falls behind it.
"""

import math
import os
import random
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

ROOT = Path(__file__).resolve().parents[1]
REPORT = re.compile(
    r"t=(\S+) s: base at height (\S+) m, tilted (\S+) deg, at x (\S+) y (\S+) m, heading (\S+) deg"
)
READY = "publishing rt/lowstate"
STANDING_HEIGHT = 0.8 * 0.30
"""Base height (m) above which a report counts as standing (go2's STANDING_FRACTION_OF_TARGET)."""
FALLEN_HEIGHT = 0.15


@dataclass
class Options:
    task: str = "go2_walk"
    """go2_walk (planned at its default command, 0.5 m/s forward) or go2_stand."""
    estimator: str = "legged"
    """The app's estimator of the base: legged (under 1 ms a reading), or ekf (30-45 ms a reading
    for the Go2, more than a robot's 500 Hz readings leave it in real time)."""
    seeds: int = 2
    """Runs, each with the robot's start and pushes seeded 0, 1, ..."""
    duration: float = 12.0
    """Wall seconds the app runs for."""
    rate_hz: float = 200.0
    """rt/lowcmd per second the bridge sends."""
    soft_start_s: float = 0.5
    """The bridge's soft start (its default is 2 s, for a robot in its harness): over 2 s a crouched
    Go2 sinks onto its belly before the gains hold it."""


def env() -> dict[str, str]:
    return {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
    }


def run_once(options: Options, seed: int) -> list[tuple[float, ...]]:
    """The robot's reports (t, height, tilt, x, y, heading) of one run, on a DDS domain of its
    own."""
    domain = random.randint(100, 200)
    unitree = ["--unitree.domain", str(domain), "--unitree.silence-s", "0.5"]
    with tempfile.TemporaryFile("w+") as log:
        robot = subprocess.Popen(
            [sys.executable, "-m", "judo", "plant", "--task", options.task, "--protocol", "unitree",
             "--seed", str(seed), *unitree],
            stdout=log, stderr=subprocess.STDOUT, text=True, env=env(), cwd=ROOT,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 120
            while READY not in _read(log) and robot.poll() is None:
                if time.monotonic() > deadline:
                    raise RuntimeError("the robot process never published rt/lowstate")
                time.sleep(0.1)
            app = subprocess.run(
                [sys.executable, "-m", "judo", "--task", options.task, "--system", "unitree",
                 *unitree, "--unitree.rate-hz", str(options.rate_hz),
                 "--unitree.soft-start-s", str(options.soft_start_s), "--estimator",
                 options.estimator, "--headless", "--duration", str(options.duration)],
                capture_output=True, text=True, env=env(), cwd=ROOT, timeout=300 + options.duration,
            )  # fmt: skip
            if app.returncode != 0:
                print(app.stderr[-2000:], file=sys.stderr)
        finally:
            robot.terminate()
            try:
                robot.wait(timeout=10)
            except subprocess.TimeoutExpired:
                robot.kill()
                robot.wait()
        text = _read(log)
    return [tuple(map(float, m)) for m in REPORT.findall(text)]


def _read(log) -> str:
    """Everything written to the open file `log` so far."""
    log.flush()
    log.seek(0)
    return log.read()


def figures(reports: list[tuple[float, ...]], command: np.ndarray) -> dict[str, float]:
    """What one run's reports say, from the robot's first second on (the robot starts in its crouch
    and sinks under damping until the app's first commands and the soft start): time_to_stand (s of
    the robot's clock, NaN if never), the standing share, falls (down again after standing), and
    the mean heading-frame speed and its error against `command` (vx, vy) after the first 3 s."""
    rows = np.array(reports, dtype=float).reshape(-1, 6)
    rows = rows[rows[:, 0] >= 1.0]
    t, z, tilt, x, y, heading = rows.T
    standing = (z > STANDING_HEIGHT) & (tilt < 30)
    falls, stood = 0, False
    for up, height, angle in zip(standing, z, tilt, strict=True):
        stood = stood or bool(up)
        if stood and (height < FALLEN_HEIGHT or angle > 60):
            falls, stood = falls + 1, False
    late = t >= 3.0
    velocity, error = math.nan, math.nan
    if late.sum() >= 2:
        dt, dx, dy = np.diff(t[late]), np.diff(x[late]), np.diff(y[late])
        yaw = np.deg2rad(heading[late][:-1])
        forward = (np.cos(yaw) * dx + np.sin(yaw) * dy) / dt
        sideways = (-np.sin(yaw) * dx + np.cos(yaw) * dy) / dt
        velocity = float(forward.mean())
        error = float(np.hypot(forward - command[0], sideways - command[1]).mean())
    yaw_rate = math.nan
    if late.sum() >= 2:
        turned = np.unwrap(np.deg2rad(heading[late]))
        yaw_rate = float((turned[-1] - turned[0]) / (t[late][-1] - t[late][0]))
    return {
        "time_to_stand": float(t[np.argmax(standing)]) if standing.any() else math.nan,
        "standing": float(standing.mean()) if len(standing) else math.nan,
        "falls": float(falls),
        "speed": velocity,
        "velocity_error": error,
        "yaw_rate": yaw_rate,
        "robot_seconds": float(t[-1]) if len(t) else 0.0,
    }


def main(options: Options) -> None:
    from judo.core.configuration.registry import make_task

    task = make_task(options.task)
    command = np.asarray(getattr(task.config, "velocity_command", np.zeros(3)), dtype=float)
    print(
        f"{options.task} over the Unitree wire on loopback, estimator {options.estimator}, "
        f"{options.seeds} seeds x {options.duration:g} s wall, command {command.tolist()}"
    )
    print("seed  robot s  time_to_stand  standing  falls  speed m/s  velocity_error m/s", end="")
    print("  yaw rate rad/s")
    rows = []
    for seed in range(options.seeds):
        start = time.monotonic()
        row = figures(run_once(options, seed), command)
        rows.append(row)
        print(
            f"{seed:>4}  {row['robot_seconds']:>7.1f}  {row['time_to_stand']:>13.2f}  "
            f"{row['standing']:>8.2f}  {row['falls']:>5.0f}  {row['speed']:>9.3f}  "
            f"{row['velocity_error']:>18.3f}  {row['yaw_rate']:>14.3f}   "
            f"({time.monotonic() - start:.0f} s wall)"
        )
    mean = {k: float(np.nanmean([r[k] for r in rows])) for k in rows[0]}
    print(
        f"mean  {mean['robot_seconds']:>7.1f}  {mean['time_to_stand']:>13.2f}  "
        f"{mean['standing']:>8.2f}  {mean['falls']:>5.1f}  {mean['speed']:>9.3f}  "
        f"{mean['velocity_error']:>18.3f}  {mean['yaw_rate']:>14.3f}"
    )


if __name__ == "__main__":
    main(tyro.cli(Options))
