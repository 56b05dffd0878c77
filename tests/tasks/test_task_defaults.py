"""The per-task defaults shipped as TOML (src/judo/tasks/models/*.toml) resolve to the recorded
configs.

task_defaults.json holds, for every built-in task, each config field that differs from its class's
default: the controller's (task-wide and per optimizer), the task's, and every built-in optimizer's.
It was recorded from the Python block that the TOML files replaced. Changing a task's TOML takes two
steps:

1. First check the candidate under the conditions a user's machine brings (20 Hz and the task's
   rate, no latency and 25 ms, or 50 ms for the LEAP and fr3 tasks), with the candidate as --config,
   and fix every collapse it flags before going on:

       PYTHONPATH=src python benchmarks/defaults_under_conditions.py --tasks TASK --seeds 5 --config candidate.toml

2. Then, second, write the TOML and regenerate this snapshot, and review the diff:

       PYTHONPATH=src python tests/tasks/test_task_defaults.py
"""  # noqa: E501

import json
import sys
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import judo  # registers the built-in tasks and optimizers
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import (
    get_registered_optimizers,
    get_registered_tasks,
    make_config,
)

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
    "quadruped",
    "quadruped_velocity",
    "quadruped_navigate",
    "car",
    "quadrotor",
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
        if not np.array_equal(
            np.asarray(getattr(config, f.name)), np.asarray(getattr(default, f.name))
        )
    }


def resolved_defaults(task_name: str) -> dict[str, Any]:
    """What the registry gives `task_name`: controller, task and per-optimizer config differences,
    and ("controller_by_optimizer", only when some optimizer has its own controller section) each
    optimizer's controller fields that differ from the task-wide controller."""
    optimizers = get_registered_optimizers()
    controller = make_config(ControllerConfig, task_name)
    resolved = {
        "controller": differences(controller),
        "task": differences(make_config(get_registered_tasks()[task_name][1], task_name)),
        "optimizers": {
            name: differences(make_config(optimizers[name][1], task_name))
            for name in BUILTIN_OPTIMIZERS
        },
    }
    own = {name: own_controller(controller, task_name, name) for name in BUILTIN_OPTIMIZERS}
    if any(own.values()):
        resolved["controller_by_optimizer"] = {
            name: fields for name, fields in own.items() if fields
        }
    return resolved


def own_controller(
    task_wide: ControllerConfig, task_name: str, optimizer_name: str
) -> dict[str, Any]:
    """The fields of the optimizer's controller config that differ from the task-wide one."""
    config = make_config(ControllerConfig, task_name, optimizer_name)
    return {
        f.name: plain(getattr(config, f.name))
        for f in fields(config)
        if not np.array_equal(
            np.asarray(getattr(config, f.name)), np.asarray(getattr(task_wide, f.name))
        )
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
    RECORD.write_text(
        json.dumps({name: resolved_defaults(name) for name in BUILTIN_TASKS}, indent=1) + "\n"
    )
    print(f"wrote {RECORD}", file=sys.stderr)
