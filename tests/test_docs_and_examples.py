"""Every python snippet in the README and docs runs, and every example runs and does what it
says."""

import importlib.util
import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SKIP_MARK = "<!-- not-run -->"  # put on the line before a ```python block that only illustrates


def python_blocks(path: Path) -> list[str]:
    """The ```python blocks of a markdown file, in order, except those marked not-run."""
    text = path.read_text()
    blocks = []
    for match in re.finditer(r"(?:^|\n)([^\n]*)\n```python\n(.*?)\n```", text, flags=re.S):
        if SKIP_MARK not in match.group(1):
            blocks.append(match.group(2))
    return blocks


@pytest.mark.parametrize("path", [p for p in DOC_FILES if python_blocks(p)], ids=lambda p: p.name)
def test_doc_snippets_run(path, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"doc_{path.stem}"}
    blocks = python_blocks(path)
    for block in blocks:  # blocks of one file share a namespace, as a reader would run them
        exec(compile(block, str(path), "exec"), namespace)
    assert blocks


def load_example(name: str):
    spec = importlib.util.spec_from_file_location(name.replace(".py", ""), ROOT / "examples" / name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_example_01_custom_task_reaches_its_goal():
    assert load_example("01_custom_task.py").main(duration=3.0) < 0.1


def test_example_02_custom_optimizer_improves_on_the_start():
    results = load_example("02_custom_optimizer.py").main(iterations=8)
    assert set(results) == {"elite_average", "mppi"}
    assert all(reward > -5000 for reward in results.values())


def test_example_04_config_file_registers_and_overrides():
    import judo

    loaded = judo.load_config(ROOT / "examples" / "04_config_file" / "judo.toml")
    assert (loaded.task, loaded.optimizer) == ("balance", "cooling_mppi")
    controller = judo.make_controller(loaded.task, loaded.optimizer, seed=0, num_workers=1)
    assert controller.config.horizon == 0.6 and controller.optimizer.config.cooling == 0.3
    assert controller.task.config.w_control == 0.05
    controller.update_action(
        controller.task.data.qpos.tolist() + controller.task.data.qvel.tolist(), 0.0
    )
    assert controller.optimizer.temperature < controller.optimizer.config.temperature  # it cooled
    controller.close()


def test_example_05_notebook_runs_and_plots(monkeypatch, tmp_path):
    import json

    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    notebook = json.loads((ROOT / "examples" / "05_notebook.ipynb").read_text())
    namespace: dict = {"__name__": "notebook"}
    monkeypatch.setattr(plt, "show", lambda: plt.savefig(tmp_path / "episode.png"))
    for cell in notebook["cells"]:
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), "05_notebook.ipynb", "exec"), namespace)
    assert (tmp_path / "episode.png").stat().st_size > 10_000
    assert namespace["result"].log.states.shape[1] == 4


def test_example_03_registers_then_runs_the_app_headless():
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "03_programmatic_registration.py"),
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
    assert "task: swing_high" in result.stdout and "optimizer: greedy_mppi" in result.stdout


def test_example_07_low_level_policy_plans_targets_and_balances():
    metrics = load_example("07_low_level_policy.py").main(duration=4.5)
    assert metrics["swung_up"] == 1.0 and metrics["balanced_fraction"] > 0.95


@pytest.mark.slow
def test_example_08_quadruped_walks_towards_its_goal_without_falling():
    metrics = load_example("08_quadruped.py").main(duration=1.5)
    # the first goal lies 1 m ahead
    assert metrics["final_distance"] < 0.5 and metrics["falls"] == 0.0


def test_example_09_plans_the_quadruped_over_its_shipped_policy_without_falling(capsys):
    metrics = load_example("09_quadruped_navigate.py").main(duration=1.0)
    # the first goal lies 1 m ahead: it walks
    assert metrics["falls"] == 0.0 and metrics["final_distance"] < 0.85
    assert "over 'quadruped_locomotion'" in capsys.readouterr().out


def test_example_12_own_dynamics_drives_around_the_obstacle_to_the_goal():
    result = load_example("12_own_dynamics.py").main(duration=6.0)
    assert result["final_distance"] < 0.1
    assert result["closest_approach"] > 0.3 + 0.05  # the obstacle's radius and a margin
