"""MuJoCo's own warnings are counted into one line every few seconds, never one terminal line
each."""

import logging
import subprocess
import sys
from pathlib import Path

import mujoco

from judo.loop.mujoco_warnings import WarningCounter

ROOT = Path(__file__).resolve().parents[2]
DIVERGE = """
from judo.loop.system import MujocoSystem, SimulationDiverged
from judo.tasks.cartpole import Cartpole
system = MujocoSystem.from_task(Cartpole(), 0)
for _ in range(500):
    system.task.data.qpos[1] = 1e300
    try:
        system.step()
    except SimulationDiverged:
        pass
print("done", flush=True)
"""


def test_a_plant_that_diverges_every_step_prints_two_lines_not_five_hundred():
    run = subprocess.run(
        [sys.executable, "-c", DIVERGE],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={"PYTHONPATH": str(ROOT / "src"), "PATH": ""},
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "done"  # MuJoCo printed nothing of its own
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 2, lines[:5]
    assert lines[0].startswith("MuJoCo: Nan, Inf or huge value in QPOS at DOF 1.")
    assert "further MuJoCo warnings are counted every 5 s" in lines[0]
    assert "MuJoCo warned 499 more times" in lines[1] and "(500 total)" in lines[1]  # said at exit
    assert (
        "499 x 'Nan, Inf or huge value in QPOS at DOF 1. The simulation is unstable.'" in lines[1]
    )


def test_the_counter_says_the_first_of_each_kind_then_counts_every_few_seconds(caplog):
    now = [0.0]
    counter = WarningCounter(report_every=5.0, clock=lambda: now[0])
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(counter)
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint/><geom size="1"/></body></worldbody></mujoco>'
    )
    try:
        with caplog.at_level(logging.WARNING, logger="judo.mujoco"):
            for i in range(300):  # a fresh MjData warns once, as a planner's rollouts each do
                data = mujoco.MjData(model)
                data.qvel[0] = 1e300
                now[0] = i * 0.01  # 3 s of warnings: one line for the first, none yet for the rest
                mujoco.mj_step(model, data)
            assert counter.total == 300 and len(caplog.records) == 1
            now[0] = 5.0
            data = mujoco.MjData(model)
            data.qvel[0] = 1e300
            mujoco.mj_step(model, data)
            assert len(caplog.records) == 2
            assert (
                caplog.records[1]
                .getMessage()
                .startswith("MuJoCo warned 300 more times in the last 5 s (301 total)")
            )
            counter.flush()  # nothing new since: no line
            assert len(caplog.records) == 2
    finally:
        mujoco.set_mju_user_warning(previous)


def test_the_same_warning_at_another_time_is_one_kind(caplog):
    counter = WarningCounter(clock=lambda: 0.0)
    text = "Nan, Inf or huge value in QACC at DOF 0. The simulation is unstable. Time = 1.5000."
    with caplog.at_level(logging.WARNING, logger="judo.mujoco"):
        counter(text)
        counter(text.replace("1.5000", "2.7500"))
        counter.flush()
    assert [r.getMessage() for r in caplog.records] == [
        f"MuJoCo: {text} (further MuJoCo warnings are counted every 5 s)",
        "MuJoCo warned 1 more times in the last 0 s (2 total): "
        "1 x 'Nan, Inf or huge value in QACC at DOF 0. The simulation is unstable.'",
    ]
