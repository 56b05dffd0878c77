"""benchmarks/safety_limits.py prints a row per case with and without limits, and no command outside
them."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_rogue_case_serves_no_command_outside_the_limits():
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "safety_limits.py"), "--cases", "rogue", "--seeds", "1",  # noqa: E501
         "--duration", "0.5", "--no-cost"],
        capture_output=True, text=True, timeout=600, env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"},  # noqa: E501
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines() if line.startswith("rogue")]
    assert [row[1] for row in rows] == ["off", "on"]
    off, on = rows
    # commands outside the effort cap: the Policy's, and none served
    assert int(off[2]) > 0 and int(on[2]) == 0
    assert int(on[5]) > 0  # the filter's hits


def test_the_grasp_case_recomputes_the_cube_resting_on_the_table_as_its_weight():
    import importlib.util

    import mujoco
    import numpy as np

    from judo.core.configuration.registry import make_task
    from judo.safety.limits import resolve

    spec = importlib.util.spec_from_file_location(
        "safety_limits", ROOT / "benchmarks" / "safety_limits.py"
    )
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    task = make_task("fr3_pick")
    _, _, config, _ = bench.CASES["grasp"]
    limits = resolve(task, config)
    model, data = task.sim_model, mujoco.MjData(task.sim_model)
    data.qpos[:] = task.data.qpos
    for _ in range(300):  # let the cube settle on the table, the arm held where it starts
        data.ctrl[:] = task.optimizer_warm_start(np.concatenate([data.qpos, data.qvel]))
        mujoco.mj_step(model, data)
    state = np.concatenate([data.qpos, data.qvel])[None]
    force = bench.contact_force(model, limits, state, data.ctrl[None].copy())
    weight = float(model.body_subtreemass[model.geom_bodyid[limits.contact_ids[0]]]) * 9.81
    assert abs(force[0] - weight) < 0.1 * weight, (force, weight)
    assert force[0] < config.max_contact_force
