"""best.toml: the writer's output is a --config file that load_config reads back to the same
values."""

import pytest

import judo
from judo.core.configuration.config_file import tomllib
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import make_config
from judo.core.errors import JudoError
from judo.optimizers.mppi import MPPIConfig
from judo.tuning.best_file import best_toml, toml_value, write_best_toml
from tests.conftest import UprightConfig, UprightTask


def test_the_best_file_round_trips_through_load_config(tmp_path):
    judo.register_task("tune_best_file_task", UprightTask, UprightConfig)
    values = {
        "controller.horizon": 0.123456789,
        "controller.spline_order": "zero",
        "controller.max_opt_iters": 3,
        "optimizer.temperature": 1e-4,
        "optimizer.num_rollouts": 48,
        "optimizer.use_noise_ramp": True,
        "task.w_upright": 2.5,
    }
    path = tmp_path / "out" / "best.toml"
    write_best_toml(
        path,
        "tune_best_file_task",
        "mppi",
        values,
        ["Best of study 'x': trial 3", "Found by: tune"],
    )
    text = path.read_text()
    assert text.startswith(
        "# Best of study 'x': trial 3\n# Found by: tune\n\ntask = "
        '"tune_best_file_task"\noptimizer = "mppi"\n\n['
    )
    assert (
        tomllib.loads(text)["optimizer_config_overrides"]["tune_best_file_task"]["mppi"][
            "temperature"
        ]
        == 1e-4
    )
    assert judo.load_config(path).task == "tune_best_file_task"
    assert (
        tomllib.loads(text)["controller_config_overrides"]["tune_best_file_task"]["mppi"][
            "max_opt_iters"
        ]
        == 3
    )
    # mppi's only
    assert (
        make_config(ControllerConfig, "tune_best_file_task").horizon == ControllerConfig().horizon
    )
    assert (
        make_config(ControllerConfig, "tune_best_file_task", "ps").horizon
        == ControllerConfig().horizon
    )
    controller = make_config(ControllerConfig, "tune_best_file_task", "mppi")
    optimizer = make_config(MPPIConfig, "tune_best_file_task")
    task = make_config(UprightConfig, "tune_best_file_task")
    assert (controller.horizon, controller.spline_order, controller.max_opt_iters) == (
        0.123456789,
        "zero",
        3,
    )
    assert (optimizer.temperature, optimizer.num_rollouts, optimizer.use_noise_ramp) == (
        1e-4,
        48,
        True,
    )
    assert task.w_upright == 2.5


def test_only_the_kinds_given_get_a_section_and_odd_values_are_refused():
    assert (
        best_toml("cartpole", "ps", {"optimizer.sigma": 0.5}) == 'task = "cartpole"\noptimizer = '
        '"ps"\n\n[optimizer_config_overrides.cartpole.ps]\nsigma = 0.5\n'
    )
    assert toml_value('say "hi"') == '"say \\"hi\\""'
    with pytest.raises(JudoError, match="non-finite value nan"):
        toml_value(float("nan"))
    with pytest.raises(
        JudoError,
        match=r"cannot write \[1, 2\] \(list\).*expected "
        r"bool, int, float or str",
    ):
        toml_value([1, 2])
