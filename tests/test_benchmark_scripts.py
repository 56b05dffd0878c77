"""The benchmark scripts run end to end on the smallest settings and print their tables."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / args[0]), *args[1:]],
        capture_output=True,
        text=True,
        timeout=300,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
        },
        cwd=ROOT,
    )


def test_task_suite_prints_a_markdown_table_per_task(tmp_path):
    out = tmp_path / "suite.md"
    small = ["--seeds", "1", "--duration", "0.3", "--timing-samples", "2", "--markdown", str(out)]
    result = run_script(
        "task_suite.py", "--tasks", "cartpole", "particle", "--optimizers", "ps", *small
    )
    assert result.returncode == 0, result.stderr
    assert "### cartpole (1 seed x 0.3 s, no latency)" in result.stdout
    assert (
        "| optimizer | update ms | rollout floor ms | overhead | balanced_fraction | swung_up |"
        in result.stdout
    )
    assert "### particle" in result.stdout and "goals_per_minute" in result.stdout
    assert out.read_text().count("| ps | ") == 2


def test_task_suite_names_the_valid_choices_for_an_unknown_task():
    result = run_script("task_suite.py", "--tasks", "cartpol")
    assert result.returncode == 2
    assert "cartpol" in result.stderr and "cartpole" in result.stderr


@pytest.mark.browser
@pytest.mark.slow  # 8-10 s: the soak script with a browser drawing the scene
def test_soak_prints_memory_threads_rates_and_the_switch_growth():
    if not Path("/usr/bin/chromium").exists():
        pytest.skip("/usr/bin/chromium not found (install Debian's chromium package)")
    result = run_script("soak.py", "--minutes", "0.03", "--sample-seconds", "1", "--switches", "5")
    assert result.returncode == 0, result.stderr
    assert "browser connected" in result.stdout
    assert " minute   rss MB  threads  control Hz    RTF" in result.stdout
    assert "soak: rss " in result.stdout and "threads " in result.stdout
    assert "switch phase after the first 4 (each model loaded once): rss " in result.stdout
    assert "Traceback" not in result.stderr


def test_served_actions_counts_actions_beyond_the_range_and_times_the_clamp():
    result = run_script(
        "served_actions.py", "--tasks", "pendulum", "--duration", "0.3", "--timing-samples", "1"
    )
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if "pendulum" in line)
    assert [cell.strip() for cell in row.split("│")[1:5]] == ["pendulum", "cubic", "30", "0"]
    assert "one Spline(t) call" in result.stdout and "cubic" in result.stdout


@pytest.mark.warp
def test_gpu_rollouts_prints_the_device_it_measured_and_a_row_per_task_and_n():
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    tiny = ["--num-rollouts", "4", "8", "--samples", "1", "--warmup", "0", "--horizon", "0.05"]
    result = run_script("gpu_rollouts.py", "--tasks", "cartpole", *tiny)
    assert result.returncode == 0, result.stderr
    out = " ".join(result.stdout.split())  # rich wraps long lines
    assert "warp device: " in out and "MuJoCo Warp" in out
    assert "cartpole │ 4 x 5 │ 1 │" in out and "cartpole │ 8 x 5 │ 1 │" in out
    assert "CPU / warp" in out and "physics" in out and "copies" in out and "reward" in out


def test_robust_planning_prints_a_row_per_setting():
    small = ["--seeds", "1", "--duration", "0.2", "--num-workers", "1", "--optimizers", "cem"]
    result = run_script(
        "robust_planning.py",
        "--task",
        "leap_cube",
        *small,
        "--randomizations",
        "1",
        "2",
        "--risks",
        "cvar",
    )
    assert result.returncode == 0, result.stderr
    assert (
        "### leap_cube on a mismatched plant (opt.o_friction=[0.9, 0.9, 0.02, 0.0001, "
        "0.0001]), 1 seed(s) from 0 x 0.2 s" in result.stdout
    )
    assert (
        "| cem | 1 | - | 0 | 0 |" in result.stdout
        and "| cem | 2 | cvar 0.5 | 0 | 0 |" in result.stdout
    )


def test_randomized_overhead_prints_the_ratio_per_r():
    small = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--samples",
        "2",
        "--warmup",
        "1",
        "--num-workers",
        "1",
    ]
    result = run_script("randomized_overhead.py", *small, "--randomizations", "1", "3")
    assert result.returncode == 0, result.stderr
    assert "| 1 | 64 x 1 x 100 |" in result.stdout and "| 3 | 64 x 3 x 100 |" in result.stdout


def test_defaults_under_conditions_prints_the_matrix_and_names_a_bad_condition(tmp_path):
    out = tmp_path / "matrix.md"
    small = ["--seeds", "1", "--duration", "0.3", "--markdown", str(out)]
    result = run_script(
        "defaults_under_conditions.py", "--tasks", "cartpole", "--optimizers", "ps", "--conditions",
        "control_freq=20,50", "latency_ms=0", *small,
    )  # fmt: skip
    assert result.returncode in (0, 1), result.stderr  # 1: a collapse was flagged
    assert "### cartpole (1 seeds from 0 x 0.3 s; **!** = collapse)" in result.stdout
    assert "| optimizer | condition | balanced_fraction | swung_up | mean_reward |" in result.stdout
    assert "| ps | control_freq=20 latency_ms=0 | " in result.stdout
    assert "| ps | control_freq=50 latency_ms=0 | " in result.stdout
    assert ("no collapse" in result.stdout) == (result.returncode == 0)
    assert out.read_text().count("| ps | ") == 2
    bad = run_script(
        "defaults_under_conditions.py", "--tasks", "cartpole", "--conditions", "latncy_ms=0"
    )
    assert bad.returncode == 2
    assert (
        "unknown condition 'latncy_ms'; valid conditions are: control_freq, latency_ms"
        in bad.stderr
    )


def test_a_collapse_is_a_tenth_of_a_fraction_or_a_quarter_of_a_rate_below_the_best_condition():
    import importlib.util

    from judo.evaluation.stats import Summary

    spec = importlib.util.spec_from_file_location(
        "matrix", ROOT / "benchmarks" / "defaults_under_conditions.py"
    )
    matrix = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(matrix)

    def summaries(**means):
        return {name: Summary(mean, 0.0, mean, mean, 5) for name, mean in means.items()}

    fractions = {
        "fast": summaries(balanced_fraction=1.0),
        "slow": summaries(balanced_fraction=0.89),
    }
    (collapse,) = matrix.collapses("cartpole", "ps", fractions)
    assert (collapse.condition, collapse.value, collapse.best_condition) == ("slow", 0.89, "fast")
    fractions["slow"] = summaries(balanced_fraction=0.9)
    assert matrix.collapses("cartpole", "ps", fractions) == []
    rates = {
        "fast": summaries(goals_per_minute=40.0, drops=0.0),
        "slow": summaries(goals_per_minute=30.5, drops=9.0),
    }
    # 24% lost; drops is lower-is-better, not judged
    assert matrix.collapses("leap_cube", "cem", rates) == []
    rates["slow"] = summaries(goals_per_minute=29.0, drops=0.0)
    assert [c.metric for c in matrix.collapses("leap_cube", "cem", rates)] == ["goals_per_minute"]


@pytest.mark.browser
@pytest.mark.slow  # 10-13 s
def test_soak_with_driver_faults_reports_the_faults_and_the_watchdog():
    if not Path("/usr/bin/chromium").exists():
        pytest.skip("/usr/bin/chromium not found (install Debian's chromium package)")
    result = run_script(
        "soak.py",
        "--minutes",
        "0.1",
        "--sample-seconds",
        "2",
        "--switches",
        "0",
        "--driver-faults",
        "1.5",
    )
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if line.startswith("driver faults: "))
    injected = int(line.split()[2])
    trips = int(line.split("safe action ")[1].split()[0])
    assert injected >= 3, result.stdout
    # one session (no switches): each fault of a second trips the watchdog
    assert trips >= 2, result.stdout


def test_estimation_prints_the_closed_loop_table_and_the_ekf_cost():
    result = run_script(
        "estimation.py",
        "--tasks",
        "pendulum",
        "--seeds",
        "1",
        "--duration",
        "0.5",
        "--cost-steps",
        "5",
        "--true-start",
        "--planner-noise",
        "0.01",
        "--first-seed",
        "2",
        "--latency-ms",
        "10",
    )
    assert result.returncode == 0, result.stderr
    modes = (
        "full state",
        "sensors + ekf",
        "sensors + ukf",
        "state, noisy + late",
        "ekf, ideal sensors",
    )
    modes += ("ekf, ideal, true start",)
    for mode in (*modes, "state + planner noise"):
        assert mode in result.stdout
    row = next(line for line in result.stdout.splitlines() if line.startswith("pendulum "))
    # 7 modes (mean ± std) and 6 ratios
    assert row.split()[1] == "upright_fraction" and len(row.split()) == 29
    assert 0.0 <= float(row.split()[17]) <= 1.0, row  # the true-start column's mean is a fraction
    assert "seeds 2-2" in result.stdout and "latency 10 ms" in result.stdout
    assert "EKF and UKF on leap_cube" in result.stdout and "relinearize_every" in result.stdout
    # the UKF's cost row
    assert any(line.split()[:1] == ["ukf"] for line in result.stdout.splitlines())


def test_low_level_policy_prints_update_floor_and_what_batching_buys():
    small = [
        "--num-rollouts",
        "4",
        "--samples",
        "1",
        "--warmup",
        "0",
        "--num-workers",
        "1",
        "--cpu-time",
    ]
    result = run_script("low_level_policy.py", *small)
    assert result.returncode == 0, result.stderr
    out = " ".join(result.stdout.split())  # rich wraps long lines
    assert (
        "cartpole_pd x ps: low-level policy inside every rollout" in out
        and "thread CPU time" in out
    )
    assert "4 x 100 │ 2 (50) │" in out and "batching buys" in out


def test_low_level_ticks_prints_a_tick_s_python_observation_and_act_per_task():
    result = run_script(
        "low_level_ticks.py", "--rounds", "1", "--repeats", "1", "--num-steps", "10"
    )
    assert result.returncode == 0, result.stderr
    out = " ".join(result.stdout.split())
    assert "a low-level tick's Python, one worker's block, thread CPU time" in out
    assert "quadruped_navigate │ 4 x 10 │ 5 │" in out and "cartpole_pd │ 32 x 10 │ 5 │" in out
    bad = run_script("low_level_ticks.py", "--tasks", "cartpole_pd", "--rows", "4", "8")
    assert (
        bad.returncode != 0
        and "--rows needs one block size per task: 1 tasks, got 2 sizes" in bad.stderr
    )


def test_proposals_prints_a_row_per_rollout_count_and_policy_samples():
    small = [
        "--optimizers",
        "ps",
        "--seeds",
        "1",
        "--duration",
        "0.3",
        "--num-workers",
        "1",
        "--num-rollouts",
        "16",
    ]
    result = run_script("proposals.py", *small, "--policy-samples", "1")
    assert result.returncode == 0, result.stderr
    out = " ".join(result.stdout.split())  # rich wraps long lines
    assert (
        "cartpole: proposals from an LQR law holding the cart at 0.2 m, seeds 100-100 x 0.3 s"
        in out
    )
    for rollouts, samples in (("16", "0"), ("16", "1"), ("2", "0"), ("2", "1")):
        assert f"│ ps │ {rollouts} │ {samples} │" in out


def test_estimator_realtime_prints_a_row_per_filter_and_thread():
    result = run_script(
        "estimator_realtime.py",
        "--tasks",
        "cartpole",
        "--filters",
        "state",
        "ekf",
        "--duration",
        "0.5",
        "--warmup",
        "0.5",
    )
    assert result.returncode == 0, result.stderr
    assert "load average at the start:" in result.stdout
    rows = [line.split("|") for line in result.stdout.splitlines() if line.startswith("cartpole")]
    assert [(row[1].strip(), row[2].strip()) for row in rows] == [
        ("state", "-"),
        ("ekf", "plant"),
        ("ekf", "own"),
    ]
    assert all(float(row[3]) > 0 for row in rows)  # a real-time factor each
    # the lag of a filter on its own thread only
    assert rows[2][5].strip() != "-" and rows[1][5].strip() == "-"


@pytest.mark.slow
def test_distill_collects_distills_and_prints_the_columns_on_fresh_seeds(tmp_path):
    pytest.importorskip("jax")
    small = [
        "--tasks",
        "pendulum",
        "--episodes",
        "2",
        "--duration",
        "0.5",
        "--rounds",
        "1",
        "--episodes-per-round",
    ]
    small += ["1", "--seeds", "1", "--workers", "1", "--workdir", str(tmp_path)]
    result = run_script("distill.py", *small)
    assert result.returncode == 0, result.stderr[-2000:]
    out = result.stdout
    assert (
        "### distill (chunk, regression, mppi; 1 fresh seeds from 1000 x 0.5 s; 2 MPC "
        "episodes + 1 rounds x 1)" in out
    )
    header = (
        "| task | metric | MPC | policy, round 0 | policy, round 1 | MPC + policy, N/8 (K=2) | "
        "MPC, N/8 |"
    )
    assert header in out and "| pendulum | upright_fraction |" in out
    assert (tmp_path / "pendulum_chunk_regression_rounds" / "round_1.h5").is_file()


def test_evaluate_fingerprint_writes_the_metrics_and_finds_a_changed_run(tmp_path):
    small = [
        "--tasks",
        "pendulum",
        "--optimizers",
        "ps",
        "--latency-ms",
        "0",
        "--seeds",
        "1",
        "--duration",
        "0.2",
    ]
    out = tmp_path / "before.json"
    result = run_script("evaluate_fingerprint.py", *small, "--out", str(out))
    assert result.returncode == 0, result.stderr
    runs = json.loads(out.read_text())
    # seed 0's row
    assert list(runs) == ["pendulum/ps/0 ms"] and runs["pendulum/ps/0 ms"][0][0] == 0
    same = run_script("evaluate_fingerprint.py", *small, "--compare", str(out))
    assert same.returncode == 0 and "1 runs compared" in same.stdout and "0 differ" in same.stdout
    runs["pendulum/ps/0 ms"][0][2] += 1  # one update more than this run makes
    out.write_text(json.dumps(runs))
    changed = run_script("evaluate_fingerprint.py", *small, "--compare", str(out))
    assert changed.returncode == 1 and "differs: pendulum/ps/0 ms" in changed.stdout


@pytest.mark.slow  # about 5 s: 8 episodes of 0.3 s in a subprocess
def test_feedback_prints_each_optimizer_with_and_without_gains_and_the_update_and_serving_times():
    small = ["--seeds", "1", "--duration", "0.3", "--plants", "heavier"]
    result = run_script("feedback.py", "--tasks", "cartpole", "--optimizers", "mppi", *small)
    assert result.returncode == 0, result.stderr
    header = (
        "| plant heavier (mass x 1.25): balanced_fraction / swung_up | 20 Hz | 10 Hz | 5 Hz | 10 "
        "Hz + 25 ms |"
    )
    assert header in result.stdout
    assert "| mppi | " in result.stdout and "| mppi + feedback | " in result.stdout
    assert (
        "mppi update in the episodes: median " in result.stdout
        and "from one state, alternating" in result.stdout
    )
    assert "us with gains" in result.stdout


def test_pytorch_mppi_comparison_runs_its_judo_half_and_asks_for_the_torch_venv():
    """The judo half prints its figures as JSON (the torch half needs a venv of its own, never
    CI's)."""
    result = run_script(
        "pytorch_mppi_comparison.py",
        "--side",
        "judo",
        "--samples",
        "8",
        "--seeds",
        "1",
        "--repeats",
        "2",
    )
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout.strip().splitlines()[-1])
    assert set(figures["update_ms"]) == {"8x75"} and figures["update_ms"]["8x75"] > 0
    assert figures["upright"] == [1.0]  # seed 0 swings up and holds
    refused = run_script("pytorch_mppi_comparison.py")
    assert refused.returncode == 1 and refused.stderr.strip() == (
        "--torch-python is needed: the interpreter of a throwaway venv with torch and pytorch-mppi"
    )


def test_control_update_prints_the_fixed_cost_of_a_small_update_on_cpu_time():
    small = [
        "--tasks",
        "cartpole",
        "--optimizers",
        "mppi",
        "--horizon",
        "0.05",
        "--samples",
        "3",
        "--num-workers",
        "1",
    ]
    result = run_script("control_update.py", *small, "--cpu-time")
    assert result.returncode == 0, result.stderr
    assert "thread CPU time" in result.stdout and "fixed cost (us)" in result.stdout
    assert "│ cartpole │ mppi      │ 32 x 5 │       1 │" in result.stdout
    refused = run_script("control_update.py", "--tasks", "cartpole", "--cpu-time")
    assert refused.returncode != 0 and "--cpu-time needs --num-workers 1" in refused.stderr


def test_fixed_cost_splits_an_update_without_physics_into_reward_and_the_rest():
    small = [
        "--tasks",
        "cartpole",
        "--num-rollouts",
        "8",
        "--horizon",
        "0.05",
        "--updates",
        "3",
        "--profile",
        "10",
    ]
    result = run_script("fixed_cost.py", *small, "--after-rollout")
    assert result.returncode == 0, result.stderr
    assert "each after a real rollout" in result.stdout
    assert (
        "update without physics" in result.stdout
        and "│ cartpole │ 8 x 5 │     1 │" in result.stdout
    )
    assert "--- cartpole: the 10 costliest functions of 3 updates without physics" in result.stdout
    # the profile names the controller's own lines (its phases)
    assert "core/controller.py" in result.stdout


def test_house_figures_counts_each_figure_on_a_small_checkout_and_this_one(tmp_path):
    files = {
        "judo/__init__.py": "",
        "judo/loop/__init__.py": "from judo.loop.run import go\n",
        "judo/loop/run.py": "from judo.core.task import Task\n\ndef "
        "go():\n    from judo.core import spline\n",
        "judo/core/__init__.py": "",
        "judo/core/task.py": "from judo.core.errors import E\nTIME_TOLERANCE = 1e-9\n",
        "judo/core/errors.py": "class E(Exception): ...  # type: ignore[misc]\n",
        "judo/core/spline.py": "x = 1\n",
        "judo/core/unused.py": 'POLICY = "policy"\nif a.optimizer is '
        "None or name == POLICY or isinstance(t, "
        "DynamicsTask):\n    pass\n",
        "judo/runtime/gui/gui.py": "a = self._plan_version != s.version\nb = n != self._edits\n"
        + "#" * 101
        + "\n",
        "judo/runtime/cli.py": "",
    }
    for name, text in files.items():
        path = tmp_path / "src" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    result = run_script("house_figures.py", "--skip-run", "--root", str(tmp_path))
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "files run per steady-state update" not in out
    assert "loop/ import closure (judo modules outside loop/): 3 (4 with packages)" in out
    assert (
        "largest package (.py files): 5 (core)" in out
        and "largest file (lines): 4 (loop/run.py)" in out
    )
    assert (
        "branches on planner or task kind: 3 (is None 1, DynamicsTask 1, PolicyController 0, "
        '"policy" 1)'
    ) in out
    assert "GUI polled change counters: 2" in out and "type: ignore: 1" in out
    assert "lines over 100 characters: 1 of 15 (6.7%)" in out
    assert "re-exporting package __init__ files (names): 1 (1 names)" in out
    assert "modules named cli.py: 1" in out and "TIME_TOLERANCE definitions: 1" in out
    shown = run_script("house_figures.py", "--skip-run", "--root", str(tmp_path), "--show").stdout
    assert (
        "  judo/core/unused.py:2: if a.optimizer is None" in shown
        and "  judo/runtime/gui/gui.py:1: " in shown
    )
    both = run_script("house_figures.py", "--skip-run", "--compare", str(tmp_path))
    assert both.returncode == 0, both.stderr
    assert "before (" in both.stdout and "GUI polled change counters:" in both.stdout


def test_the_unitree_walk_figures_come_from_the_robots_true_base_after_its_first_second():
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "unitree_walk", ROOT / "benchmarks" / "unitree_walk.py"
    )
    walk = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(walk)
    # (t, height, tilt, x, y, heading): crouched, sunk under damping, then up and walking at
    # 0.4 m/s along a heading of 90 degrees (+y), turning at 0.1 rad/s from t = 3 s on
    reports = [(0.0, 0.25, 1, 0, 0, 90), (1.0, 0.09, 3, 0, 0, 90), (2.0, 0.30, 2, 0, 0, 90)]
    reports += [(t, 0.30, 2, 0.0, 0.4 * (t - 3), 90 + 5.73 * (t - 3)) for t in (3.0, 4.0, 5.0)]
    row = walk.figures(reports, np.array([0.5, 0.0]))
    assert row["time_to_stand"] == 2.0 and row["falls"] == 0 and row["standing"] == 0.8
    assert row["speed"] == pytest.approx(0.4, abs=0.01)
    assert row["velocity_error"] == pytest.approx(0.1, abs=0.01)
    assert row["yaw_rate"] == pytest.approx(0.1, abs=0.001)
    fallen = [*reports, (6.0, 0.08, 170, 0.0, 1.2, 90)]
    assert walk.figures(fallen, np.array([0.5, 0.0]))["falls"] == 1


@pytest.mark.slow
def test_unitree_walk_runs_the_robot_and_the_app_over_dds_and_prints_a_row_per_seed():
    pytest.importorskip("cyclonedds")
    result = run_script("unitree_walk.py", "--task", "go2_stand", "--seeds", "1", "--duration", "5")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("go2_stand over the Unitree wire on loopback, estimator legged")
    seed = lines[2].split()
    assert seed[0] == "0" and float(seed[1]) >= 3.0  # the robot's clock ran
    assert float(seed[4]) == 0  # no fall
