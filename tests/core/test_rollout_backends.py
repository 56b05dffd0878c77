"""Choosing a rollout backend: the names, the optional warp extra, and what happens without it.

These run without warp: "warp missing" is made real by blocking the import in sys.modules.
"""

import subprocess
import sys

import mujoco
import pytest

import judo
from judo.core.errors import MissingExtraError, UnknownNameError
from judo.core.rollouts.backend import ROLLOUT_BACKENDS, RolloutBackend
from judo.core.rollouts.factory import (
    BACKEND_CLASSES,
    backend_class,
    check_rollout_backend,
    make_rollout_backend,
)
from judo.core.rollouts.rollout import RolloutPool
from judo.evaluation import benchmark, evaluate
from judo.runtime import launch

MISSING_WARP = (
    "the warp rollout backend (--backend warp) needs the optional extra judo-mpc[warp], "
    "which is not installed "
    "(no module 'warp'); install it with: pip install -e \".[warp]\" (from a checkout) or "
    'pip install "judo-mpc[warp]"'
)


@pytest.fixture
def without_warp(monkeypatch):
    """warp and mujoco_warp cannot be imported (as on a machine without judo-mpc[warp]) for this
    test."""
    monkeypatch.setitem(sys.modules, "warp", None)
    monkeypatch.setitem(sys.modules, "mujoco_warp", None)
    monkeypatch.delitem(sys.modules, "judo.core.rollouts.warp_rollout", raising=False)


def test_import_judo_imports_no_warp():
    code = (
        "import sys, judo, judo.core.rollouts.backend, judo.core.rollouts.rollout; "
        "print(sorted(m for m in sys.modules if 'warp' in m))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"


def test_backend_names_are_checked_and_listed(tiny_model_path):
    assert ROLLOUT_BACKENDS == ("cpu", "warp")
    with pytest.raises(
        UnknownNameError,
        match="unknown rollout backend 'gpu'; valid rollout backends are: cpu, warp",
    ):
        check_rollout_backend("gpu")
    with pytest.raises(UnknownNameError, match="valid rollout backends are: cpu, warp"):
        judo.make_controller("cartpole", "mppi", backend="cuda")
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with make_rollout_backend("cpu", model, 1) as pool:
        assert type(pool) is RolloutPool and pool.num_workers == 1
    assert set(BACKEND_CLASSES) == set(ROLLOUT_BACKENDS) and backend_class("cpu") is RolloutPool
    assert issubclass(backend_class("cpu"), RolloutBackend)


def test_without_the_extra_the_warp_backend_names_it(without_warp, tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with pytest.raises(MissingExtraError) as caught:
        make_rollout_backend("warp", model)
    assert str(caught.value) == MISSING_WARP and caught.value.extra == "warp"
    with pytest.raises(MissingExtraError, match=r'pip install -e "\.\[warp\]"'):
        judo.make_controller("cartpole", "mppi", backend="warp")
    with pytest.raises(MissingExtraError, match=r'pip install -e "\.\[warp\]"'):
        judo.App("cartpole", "mppi", backend="warp", gui=False)


def test_without_the_extra_every_command_fails_at_once_naming_it(without_warp, capsys):
    assert (
        launch.main(["--task", "cartpole", "--backend", "warp", "--headless", "--duration", "1"])
        == 2
    )
    assert capsys.readouterr().err.strip() == f"python -m judo: {MISSING_WARP}"
    for command in (
        lambda: benchmark.main(["--tasks", "cartpole", "--backend", "warp", "--samples", "1"]),
        lambda: evaluate.main(
            [
                "--task",
                "cartpole",
                "--optimizer",
                "mppi",
                "--backend",
                "warp",
                "--seeds",
                "1",
                "--duration",
                "0.1",
            ]
        ),
    ):
        with pytest.raises(SystemExit) as exit_info:
            command()
        assert exit_info.value.code == 2
        assert capsys.readouterr().err.strip() == f"error: {MISSING_WARP}"


def test_an_unknown_backend_on_the_command_line_lists_the_valid_ones(capsys):
    with pytest.raises(SystemExit) as exit_info:
        launch.main(["--task", "cartpole", "--backend", "gpu", "--headless", "--duration", "1"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--backend" in err and "cpu" in err and "warp" in err
