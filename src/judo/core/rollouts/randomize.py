"""Domain randomization: perturbed copies of a task's planning model, built by its `randomize_model`
hook.

`randomized_models` returns the planning model itself followed by perturbed copies, each built once
per redraw (a copy of the model, the task's hook, a check of the fields it may have broken, then
`mj_setConst` so derived constants such as subtree masses follow the new values). The helpers below
draw the usual perturbations, one uniform factor per element, for task hooks to call.
"""

from collections.abc import Sequence

import mujoco
import numpy as np

from judo.core.errors import JudoError
from judo.core.model import object_id
from judo.core.task import Task

NONNEGATIVE_FIELDS = (
    "body_mass",
    "body_inertia",
    "geom_friction",
    "dof_damping",
    "dof_armature",
    "dof_frictionloss",
    "jnt_stiffness",
    "actuator_gear",
)
"""Model fields whose entries must stay finite and >= 0 after a task's hook; every other float field
the hook changed must stay finite."""


class InvalidRandomizedModelError(JudoError):
    """A task's `randomize_model` hook left a field with a NaN, an infinity, or a negative entry
    where only nonnegative values make sense (a mass, an inertia, a friction, a damping)."""


def randomized_models(task: Task, count: int, rng: np.random.Generator) -> list[mujoco.MjModel]:
    """The `count` models a randomized batch rolls out under: `task.model` itself, then count - 1
    perturbed copies, each made by `task.randomize_model(copy, rng)` and checked by
    `check_randomized_model`.

    Raises InvalidRandomizedModelError naming the field when a hook breaks one.
    """
    models = [task.model]
    for _ in range(count - 1):
        model = _copy_model(task.model)
        task.randomize_model(model, rng)
        check_randomized_model(task.model, model, f"{type(task).__name__}.randomize_model")
        mujoco.mj_setConst(model, mujoco.MjData(model))
        models.append(model)
    return models


def _copy_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """An independent copy of `model` (its arrays are not shared)."""
    import copy

    return copy.deepcopy(model)


def check_randomized_model(
    original: mujoco.MjModel, randomized: mujoco.MjModel, source: str
) -> None:
    """Raise InvalidRandomizedModelError unless every float field that `source` changed is finite
    and each of NONNEGATIVE_FIELDS is >= 0; the message names the field, the entry and the value."""
    for name in _float_fields(original):
        before, after = getattr(original, name), getattr(randomized, name)
        if before.shape != after.shape:
            raise InvalidRandomizedModelError(
                f"{source} changed the shape of {name} from {before.shape} to {after.shape}"
            )
        changed = ~((before == after) | (np.isnan(before) & np.isnan(after)))
        bad = changed & ~np.isfinite(after)
        if name in NONNEGATIVE_FIELDS:
            bad |= changed & (after < 0)
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0])
            expected = "a finite value >= 0" if name in NONNEGATIVE_FIELDS else "a finite value"
            raise InvalidRandomizedModelError(
                f"{source} set "
                f"{name}[{', '.join(map(str, index))}]{_owner(original, name, index[0])} to "
                f"{float(after[index])!r}; expected {expected} (it was {float(before[index])!r})"
            )


OWNERS = {
    "body_": mujoco.mjtObj.mjOBJ_BODY,
    "geom_": mujoco.mjtObj.mjOBJ_GEOM,
    "jnt_": mujoco.mjtObj.mjOBJ_JOINT,
    "actuator_": mujoco.mjtObj.mjOBJ_ACTUATOR,
}
"""Field prefix -> the kind of object whose row it is, for naming it in errors."""


def _owner(model: mujoco.MjModel, field: str, row: int) -> str:
    """' (body "cube")' for row `row` of `field`, or "" when the row's object has no name."""
    if field.startswith("dof_"):
        field, row = "jnt_", int(model.dof_jntid[row])
    for prefix, obj_type in OWNERS.items():
        if field.startswith(prefix):
            name = mujoco.mj_id2name(model, obj_type, row)
            return f" ({prefix.rstrip('_').replace('jnt', 'joint')} {name!r})" if name else ""
    return ""


def _float_fields(model: mujoco.MjModel) -> list[str]:
    """Names of the model's float array fields (body_mass, geom_friction, ...)."""
    return [
        name
        for name in dir(model)
        if not name.startswith("_")
        and isinstance(value := getattr(model, name), np.ndarray)
        and value.dtype.kind == "f"
    ]


def scale_geom_friction(
    model: mujoco.MjModel, geoms: Sequence[int], low: float, high: float, rng: np.random.Generator
) -> None:
    """Multiply the sliding friction of each of `geoms` (ids) by its own factor drawn uniformly from
    [low, high]."""
    model.geom_friction[list(geoms), 0] *= rng.uniform(low, high, len(geoms))


def scale_body_mass(
    model: mujoco.MjModel, body: int, low: float, high: float, rng: np.random.Generator
) -> None:
    """Multiply the mass and inertia of `body` (id) by one factor drawn uniformly from [low, high]
    (same density distribution, so the inertia scales with the mass)."""
    factor = rng.uniform(low, high)
    model.body_mass[body] *= factor
    model.body_inertia[body] *= factor


def scale_dof_frictionloss(
    model: mujoco.MjModel, dofs: Sequence[int], low: float, high: float, rng: np.random.Generator
) -> None:
    """Multiply the friction loss of `dofs` (ids) by one common factor drawn uniformly from [low,
    high]."""
    model.dof_frictionloss[list(dofs)] *= rng.uniform(low, high)


def geom_ids(model: mujoco.MjModel, geom_names: Sequence[str]) -> list[int]:
    """Ids of the geoms called `geom_names`; UnknownNameError (listing the geoms) for a missing
    one."""
    return [
        object_id(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom, name, "geom") for name in geom_names
    ]


def body_id(model: mujoco.MjModel, name: str) -> int:
    """Id of the body called `name`; UnknownNameError (listing the bodies) if there is none."""
    return object_id(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody, name, "body")


def contact_geom_ids(model: mujoco.MjModel) -> list[int]:
    """Ids of the geoms that can collide (nonzero contype or conaffinity), in id order."""
    return [
        int(i) for i in np.flatnonzero((model.geom_contype != 0) | (model.geom_conaffinity != 0))
    ]
