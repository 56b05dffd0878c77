"""The public API: every exported name exists and is documented in docs/api.md."""

import re
from pathlib import Path

import judo

API_DOC = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text()


def test_every_public_name_exists_and_is_documented():
    documented = set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)", API_DOC))
    missing = [name for name in judo.__all__ if name not in documented]
    assert not missing, f"add these to docs/api.md: {missing}"
    assert all(hasattr(judo, name) for name in judo.__all__)


def test_import_judo_registers_every_built_in_task_optimizer_and_estimator_from_its_own_module():
    from judo.builtin import BUILTIN_ESTIMATORS, BUILTIN_OPTIMIZERS, BUILTIN_TASKS

    tables = {
        "tasks": (BUILTIN_TASKS, judo.get_registered_tasks()),
        "optimizers": (BUILTIN_OPTIMIZERS, judo.get_registered_optimizers()),
        "estimators": (BUILTIN_ESTIMATORS, judo.get_registered_estimators()),
    }
    for package, (builtin, registered) in tables.items():
        for name, (cls, config_cls) in builtin.items():
            assert registered[name] == (cls, config_cls), name
            # each class and its config are defined in one module of the package, not gathered in
            # its __init__
            assert cls.__module__.startswith(
                f"judo.{package}."
            ) and config_cls.__module__.startswith(f"judo.{package}.")
    assert (
        len(BUILTIN_TASKS) == 21
        # the first twelve, cartpole_pd, quadruped, quadruped_velocity, quadruped_navigate, car,
        # quadrotor, g1_stand,
    )
    # go2_stand and go2_walk
    assert len(BUILTIN_OPTIMIZERS) == 11 and set(BUILTIN_ESTIMATORS) == {
        "state",
        "ekf",
        "ukf",
        "legged",
    }
