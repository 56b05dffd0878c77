"""The planning model on MuJoCo Warp's device: `put_model`, and the fields in which randomized
models differ.

MuJoCo Warp holds most model fields once for all worlds, and some (masses, inertias, frictions,
dampings, gains: those its types declare with a leading "*" dimension) optionally once per world.
`varying_fields` finds the fields in which a set of models differ, so that `WarpRollout` can give
exactly those one row per world.

Importing this module imports warp and mujoco_warp (the `judo[warp]` extra).
"""

import dataclasses
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import JudoError, import_extra
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RandomizedRolloutError

FEATURE = "the warp rollout backend (--backend warp)"
wp = import_extra("warp", FEATURE, "warp")
mjw = import_extra("mujoco_warp", FEATURE, "warp")

wp.config.log_level = wp.LOG_WARNING  # no line per compiled kernel module


class WarpUnsupportedModelError(JudoError):
    """A model that MuJoCo Warp cannot run (a feature its put_model does not implement)."""


def put_model(
    model: mujoco.MjModel, deterministic: bool, batch_sizes: dict[str, int] | None = None
):
    """`model` on the current warp device (the fields in `batch_sizes` with that many rows, one per
    world), or WarpUnsupportedModelError naming the feature MuJoCo Warp lacks."""
    try:
        device_model = mjw.put_model(model, batch_sizes=batch_sizes)
    except (NotImplementedError, ValueError) as err:
        raise WarpUnsupportedModelError(
            f"MuJoCo Warp {mjw.__version__} cannot run this model: {err}; expected a model "
            "without that feature. "
            "Run it on the CPU instead with --backend cpu (backend='cpu'), or change the model."
        ) from err
    # reported (and fixed) by WarpRollout, not printed from kernels
    device_model.opt.warn_overflow = 0
    device_model.opt.deterministic = int(
        mjw.DeterminismType.ALL if deterministic else mjw.DeterminismType.NONE
    )
    return device_model


def varying_fields(
    model: mujoco.MjModel, models: Sequence[mujoco.MjModel], deterministic: bool
) -> dict[str, np.ndarray]:
    """The device-model fields in which `models` differ from `model`, as MuJoCo Warp lays them out:
    field name -> (R, *field shape) values, one row per model. Comparing the uploaded models (not
    the MjModels) also catches what put_model derives from a changed field, and what `mj_setConst`
    recomputed.

    Raises RandomizedRolloutError naming a field that differs and that MuJoCo Warp holds once for
    all worlds."""
    base = put_model(model, deterministic)
    uploaded = [base if other is model else put_model(other, deterministic) for other in models]
    varying: dict[str, np.ndarray] = {}
    for name, spec, arrays in _array_fields(base, uploaded):
        values = [array.numpy() for array in arrays]
        reference = _field(base, name).numpy()
        if all(_same(value, reference) for value in values):
            continue
        if "." in name or not spec or spec[0] != "*":
            raise RandomizedRolloutError(
                f"the models given to set_models differ in {name}, which MuJoCo Warp "
                f"{mjw.__version__} holds once "
                "for all worlds; expected models that differ only in fields it holds per "
                "world (body_mass, "
                "body_inertia, geom_friction, dof_damping, actuator_gainprm and the like), "
                "or the cpu backend"
            )
        # each (1, *field shape): one world
        varying[name] = np.stack([value[0] for value in values])
    return varying


def _array_fields(base: Any, uploaded: list[Any]) -> list[tuple[str, tuple, list[Any]]]:
    """(name, spec shape, each uploaded model's array) of every warp-array field of the device model
    and of its nested option structs (named "opt.timestep" and the like)."""
    fields = []
    for field in dataclasses.fields(base):
        value = getattr(base, field.name)
        if isinstance(value, wp.array):
            fields.append(
                (
                    field.name,
                    getattr(field.type, "shape", ()),
                    [getattr(m, field.name) for m in uploaded],
                )
            )
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            for inner in dataclasses.fields(value):
                if isinstance(getattr(value, inner.name), wp.array):
                    arrays = [getattr(getattr(m, field.name), inner.name) for m in uploaded]
                    fields.append((f"{field.name}.{inner.name}", (), arrays))
    return fields


def _field(device_model: Any, name: str) -> Any:
    """The array called `name` ("body_mass", "opt.timestep") of a device model."""
    for part in name.split("."):
        device_model = getattr(device_model, part)
    return device_model


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays hold the same values (NaNs in the same places count as equal)."""
    return a.shape == b.shape and bool(np.all((a == b) | ((a != a) & (b != b))))


def probe_sizes(model: mujoco.MjModel, states: list[np.ndarray]) -> tuple[int, int]:
    """(contacts, constraint rows) MuJoCo finds at the model's reference pose, each keyframe and
    each of the full-physics `states`: the starting point for sizing MuJoCo Warp's per-world
    buffers."""
    data = mujoco.MjData(model)
    ncon = nefc = 0
    poses = [None, *range(model.nkey)]
    for pose in [*poses, *states]:
        if pose is None:
            mujoco.mj_resetData(model, data)
        elif isinstance(pose, int):
            mujoco.mj_resetDataKeyframe(model, data, pose)
        else:
            mujoco.mj_setState(model, data, pose, STATE_SPEC)
        mujoco.mj_forward(model, data)
        ncon, nefc = max(ncon, data.ncon), max(nefc, data.nefc)
    return ncon, nefc
