"""The per-task defaults shipped as TOML (src/judo/tasks/models/*.toml) resolve to the recorded configs.

task_defaults.json holds, for every built-in task, each config field that differs from its class's
default: the controller's, the task's, and every built-in optimizer's. It was recorded from the Python
block that the TOML files replaced; after a re-tune, regenerate it and review the diff:

    PYTHONPATH=src python tests/tasks/test_task_defaults.py
"""

import json
import sys
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import judo  # noqa: F401  (registers the built-in tasks and optimizers)
from judo.core.controller import ControllerConfig
from judo.core.registry import get_registered_optimizers, get_registered_tasks, make_config

RECORD = Path(__file__).with_name("task_defaults.json")
BUILTIN_TASKS = (
    "cartpole",
    "cylinder_push",
    "pendulum",
    "particle",
    "acrobot",
    "double_cartpole",
    "push_t",
    "walker",
    "humanoid_standup",
    "leap_cube",
    "leap_cube_down",
    "fr3_pick",
)
BUILTIN_OPTIMIZERS = ("ps", "cem", "mppi", "dial", "cmaes", "icem")


def plain(value: Any) -> Any:
    """`value` as JSON holds it (arrays as lists)."""
    return value.tolist() if isinstance(value, np.ndarray) else value


def differences(config: Any) -> dict[str, Any]:
    """The fields of `config` whose value differs from its class's default."""
    default = type(config)()
    return {
        f.name: plain(getattr(config, f.name))
        for f in fields(config)
        if not np.array_equal(np.asarray(getattr(config, f.name)), np.asarray(getattr(default, f.name)))
    }


def resolved_defaults(task_name: str) -> dict[str, Any]:
    """What the registry gives `task_name`: controller, task and per-optimizer config differences."""
    optimizers = get_registered_optimizers()
    return {
        "controller": differences(make_config(ControllerConfig, task_name)),
        "task": differences(make_config(get_registered_tasks()[task_name][1], task_name)),
        "optimizers": {name: differences(make_config(optimizers[name][1], task_name)) for name in BUILTIN_OPTIMIZERS},
    }


@pytest.mark.parametrize("task_name", BUILTIN_TASKS)
def test_every_task_resolves_to_the_recorded_defaults(task_name):
    recorded = json.loads(RECORD.read_text())[task_name]
    assert resolved_defaults(task_name) == recorded


def test_every_builtin_task_has_a_record_and_a_defaults_file():
    assert set(json.loads(RECORD.read_text())) == set(BUILTIN_TASKS)
    models = Path(judo.__file__).parent / "tasks" / "models"
    assert all((models / f"{name}.toml").is_file() for name in BUILTIN_TASKS)


if __name__ == "__main__":
    RECORD.write_text(json.dumps({name: resolved_defaults(name) for name in BUILTIN_TASKS}, indent=1) + "\n")
    print(f"wrote {RECORD}", file=sys.stderr)
