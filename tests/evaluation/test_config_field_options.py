"""`evaluate` takes the pair's optimizer and task config fields as --optimizer-config.FIELD and
--task-config.FIELD."""

import json

import pytest

from judo.core.configuration import registry
from judo.core.configuration.registry import make_config
from judo.evaluation import evaluate
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.optimizers.mppi import MPPIConfig
from judo.tasks.cartpole import CartpoleConfig

TINY = [
    "--task",
    "cartpole",
    "--optimizer",
    "mppi",
    "--seeds",
    "1",
    "--duration",
    "0.3",
    "--num-workers",
    "1",
]


def registry_tables() -> list[dict]:
    """Copies of the process-wide config and model overrides that every later make_config and
    make_task read."""
    return [
        {key: dict(value) for key, value in table.items()}
        for table in (registry._OVERRIDES, registry._MODEL_OVERRIDES)
    ]


def test_the_fields_given_are_the_configs_the_episodes_run_with(tmp_path, capsys):
    assert evaluate.main([*TINY, "--json", str(tmp_path / "default.json")]) == 0
    fields = ["--optimizer-config.num-rollouts", "8", "--task-config.w-control", "1000"]
    assert evaluate.main([*TINY, *fields, "--json", str(tmp_path / "changed.json")]) == 0
    default, changed = (
        json.loads((tmp_path / f"{name}.json").read_text()) for name in ("default", "changed")
    )
    assert changed["overrides"] == {"optimizer.num_rollouts": 8, "task.w_control": 1000.0}
    mean_reward = [report["episodes"][0]["metrics"]["mean_reward"] for report in (default, changed)]
    assert mean_reward[1] != mean_reward[0]  # the same seed under other weights and rollouts
    assert "optimizer.num_rollouts=8, task.w_control=1000.0" in capsys.readouterr().out


def test_the_flags_never_touch_the_process_wide_registry(tmp_path):
    """The flags travel in the episodes' spec (bit for bit the episode of that spec): the registry
    every later make_config and make_task reads stays as it was."""
    before = registry_tables()
    default_rollouts = make_config(MPPIConfig, "cartpole").num_rollouts
    flags = ["--optimizer-config.num-rollouts", "8", "--task-config.w-control", "1000"]
    flags += ["--controller.horizon", "0.5", "--plant-overrides", "body_mass.pole=0.2"]
    assert evaluate.main([*TINY, *flags, "--json", str(tmp_path / "out.json")]) == 0
    assert registry_tables() == before
    assert make_config(MPPIConfig, "cartpole").num_rollouts == default_rollouts
    assert make_config(CartpoleConfig, "cartpole").w_control == CartpoleConfig().w_control
    metrics = json.loads((tmp_path / "out.json").read_text())["episodes"][0]["metrics"]
    values = {"optimizer.num_rollouts": 8, "task.w_control": 1000.0, "controller.horizon": 0.5}
    heavier = EpisodeSpec(
        "cartpole", "mppi", 0.3, values=values, plant_overrides=("body_mass.pole=0.2",)
    )
    assert run_seeded_episode(heavier, 0).metrics == metrics
    assert (
        run_seeded_episode(EpisodeSpec("cartpole", "mppi", 0.3, values=values), 0).metrics
        != metrics
    )


def test_help_lists_the_fields_of_the_pair_named(capsys):
    with pytest.raises(SystemExit):
        evaluate.main(["--task", "cartpole", "--optimizer", "mppi", "--help"])
    text = capsys.readouterr().out
    assert (
        "--optimizer-config.temperature FLOAT" in text and "--task-config.w-vertical FLOAT" in text
    )
    assert "Fields of the optimizer's config (MPPIConfig) to change." in text


def test_a_value_the_config_refuses_fails_cleanly(capsys):
    with pytest.raises(SystemExit) as exit_info:
        evaluate.main([*TINY, "--optimizer-config.num-rollouts", "0"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "num_rollouts" in err
