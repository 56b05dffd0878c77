"""`python -m judo collect` on a real local Ray with 2 CPUs: resume, a --config task with
--success-only, Ctrl-C."""

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from judo.collection.collect import main as collect_main
from judo.core.configuration import registry
from tests.conftest import TINY_CARTPOLE_XML

h5py = pytest.importorskip("h5py")
# skipped without the extra; the local_ray fixture is in tests/conftest.py
pytest.importorskip("ray")

CARTPOLE = ["--task", "cartpole", "--optimizer", "ps", "--duration", "0.3", "--workers", "2"]

USER_MODULE = '''
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import judo

@dataclass
class StartRightConfig(judo.TaskConfig):
    w_upright: float = 1.0
    """Weight on the pole's height."""

class StartRight(judo.Task[StartRightConfig]):
    """The tiny cart-pole from a random cart position; a success when the cart starts right of centre."""

    def __init__(self):
        super().__init__(Path(__file__).with_name("tiny.xml"))

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -config.w_upright * (1.0 - np.cos(states[..., 1])).sum(-1)

    def reset(self):
        super().reset()
        self.data.qpos[0] = self.rng.uniform(-1.0, 1.0)

    def metrics(self, log):
        return {"start_x": float(log.states[0, 0])}

    def success(self, metrics):
        return metrics["start_x"] > 0.0
'''  # noqa: E501


@pytest.fixture
def restored_registry():
    """Undo what a --config file registers and overrides in this process."""
    saved = dict(registry._OVERRIDES), dict(registry._TASKS)
    yield
    registry._OVERRIDES.clear()
    registry._OVERRIDES.update(saved[0])
    registry._TASKS.clear()
    registry._TASKS.update(saved[1])


def demos(path) -> dict[str, np.ndarray]:
    """{demo name: its actions}."""
    with h5py.File(path, "r") as file:
        return {name: file["data"][name]["actions"][:] for name in file["data"]}


@pytest.mark.slow
def test_the_same_command_with_more_episodes_adds_exactly_the_missing_seeds(
    local_ray, tmp_path, capsys
):
    out = tmp_path / "cartpole.h5"
    assert collect_main([*CARTPOLE, "--episodes", "3", "--out", str(out)]) == 0
    first = demos(out)
    assert sorted(first) == ["demo_0", "demo_1", "demo_2"]
    assert collect_main([*CARTPOLE, "--episodes", "5", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert (
        "3 seeds done; running the 2 missing ones" in printed
        and "holds 5 episodes, 150 samples" in printed
    )
    second = demos(out)
    assert sorted(second) == [f"demo_{seed}" for seed in range(5)]
    assert all(np.array_equal(first[name], second[name]) for name in first)  # untouched
    assert collect_main([*CARTPOLE, "--episodes", "5", "--out", str(out)]) == 0
    assert "already holds seeds 0 to 4" in capsys.readouterr().out


@pytest.mark.slow
def test_first_seed_adds_its_own_seeds_to_the_same_file_and_resumes_them(
    local_ray, tmp_path, capsys
):
    out = tmp_path / "cartpole.h5"
    assert collect_main([*CARTPOLE, "--episodes", "1", "--out", str(out)]) == 0
    assert (
        collect_main([*CARTPOLE, "--first-seed", "10", "--episodes", "2", "--out", str(out)]) == 0
    )
    # first_seed is not part of env_args
    assert sorted(demos(out)) == ["demo_0", "demo_10", "demo_11"]
    capsys.readouterr()
    assert (
        collect_main([*CARTPOLE, "--first-seed", "10", "--episodes", "3", "--out", str(out)]) == 0
    )
    assert "2 seeds done; running the 1 missing ones" in capsys.readouterr().out
    with h5py.File(out, "r") as file:
        assert sorted(int(demo.attrs["seed"]) for demo in file["data"].values()) == [0, 10, 11, 12]
    assert (
        collect_main([*CARTPOLE, "--first-seed", "10", "--episodes", "3", "--out", str(out)]) == 0
    )
    assert "already holds seeds 10 to 12" in capsys.readouterr().out


@pytest.mark.slow
def test_a_config_file_task_with_success_only_keeps_the_successes(
    local_ray, restored_registry, tmp_path, capsys
):
    module = f"start_right_{tmp_path.name.replace('-', '_')}"
    (tmp_path / f"{module}.py").write_text(USER_MODULE)
    (tmp_path / "tiny.xml").write_text(TINY_CARTPOLE_XML)
    config = tmp_path / "judo.toml"
    config.write_text(
        f'[custom_tasks.{module}]\ntask = "{module}.StartRight"\nconfig = '
        f'"{module}.StartRightConfig"\n'
    )
    out = tmp_path / "start_right.h5"
    argv = [
        "--config",
        str(config),
        "--task",
        module,
        "--optimizer",
        "ps",
        "--duration",
        "0.1",
        "--workers",
        "2",
    ]
    assert (
        collect_main(
            [
                *argv,
                "--episodes",
                "8",
                "--success-only",
                "--traces",
                "--out",
                str(out),
                "--task-config.w-upright",
                "2",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    with h5py.File(out, "r") as file:
        kept = {int(name.removeprefix("demo_")) for name in file["data"]}
        dropped = {
            int(seed): json.loads(metrics) for seed, metrics in file["judo/dropped"].attrs.items()
        }
        assert all(file["data"][f"demo_{seed}"].attrs["success"] for seed in kept)
        starts = [
            json.loads(file["data"][f"demo_{seed}"].attrs["metrics"])["start_x"] for seed in kept
        ]
        # --traces: the tip's, nominal + 5
        traces = [file["data"][f"demo_{seed}/plan/traces"] for seed in kept]
        assert all(
            t.dtype == np.float32 and t.shape[0] >= 1 and t.shape[1] == 6 and t.shape[3:] == (1, 3)
            for t in traces
        )
        env_args = json.loads(file["data"].attrs["env_args"])
    assert kept and dropped and kept | set(dropped) == set(range(8)) and not kept & set(dropped)
    assert all(x > 0 for x in starts) and all(
        metrics["start_x"] <= 0 for metrics in dropped.values()
    )
    assert f"--success-only: dropped {len(dropped)} of 8 episodes run" in printed
    assert (
        env_args["task"] == module
        and env_args["env_kwargs"]["task"] == {"w_upright": 2.0}
        and env_args["traces"]
    )


@pytest.mark.slow
def test_ctrl_c_keeps_the_finished_episodes_in_a_file_that_opens(tmp_path):
    out = tmp_path / "stopped.h5"
    argv = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--duration",
        "1",
        "--workers",
        "1",
        "--episodes",
        "200",
    ]
    collect = subprocess.Popen(
        [sys.executable, "-m", "judo", "collect", *argv, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 240
        while (
            time.monotonic() < deadline and collect.poll() is None and len(demos_or_none(out)) < 2
        ):
            time.sleep(0.5)
        collect.send_signal(signal.SIGINT)
        _, err = collect.communicate(timeout=60)
    finally:
        if collect.poll() is None:
            collect.kill()
    assert collect.returncode == 130, err
    assert f"resume with:\n  python -m judo collect {' '.join(argv)} --out {out}" in err
    kept = demos(out)
    assert 2 <= len(kept) < 200 and all(len(actions) == 100 for actions in kept.values())


def demos_or_none(path) -> list[str]:
    """The demo names in `path`, or [] while it does not exist or is being written."""
    try:
        with h5py.File(path, "r") as file:
            return list(file["data"])
    except (OSError, KeyError):
        return []
