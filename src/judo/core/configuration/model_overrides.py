"""Model parameters as configuration: named MjModel fields set by element name.

A model override is `{field: {element: value}}`, as TOML writes `body_mass.pole = 0.13` under
`[model_overrides.TASK]` (the planning model) or `[plant_overrides.TASK]` (the simulated plant
only):

    body_mass.pole = 0.13                       # model.body_mass[id of body "pole"]
    dof_damping.slider = 0.5                    # the dofs of joint "slider"
    geom_friction.cube = [0.9, 0.005, 0.0001]   # a row of 3
    actuator_gear.push = 9.1                    # the leading entries of a row (gear[0]), as MJCF reads gear="9.1"

A field is a float array of MjModel with one row per element of a kind (body_, jnt_, dof_, geom_,
site_, actuator_, tendon_, pair_, eq_); `dof_` fields are set by joint name, over the joint's dofs.
`opt.NAME` sets MjOption's float settings (`opt.o_friction = [0.9, 0.9, 0.02, 0.0001, 0.0001]`
overrides every contact's friction and turns on MuJoCo's contact override flag, as MJCF's <flag
override="enable"/> does). A value is a number or a list of at most the row's length, which sets the
row's leading entries. Every name and shape is checked against a model before anything is set, and
so is the model they make: one MuJoCo can simulate (judo.core.configuration.model_override_checks).
"""  # noqa: E501

import copy
import sys
import typing
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError, UnknownNameError
from judo.core.model import names

if typing.TYPE_CHECKING:
    from judo.core.task import Task

ModelOverrides = dict[str, dict[str, Any]]
"""{field: {element name: value}}, e.g. {"body_mass": {"pole": 0.13}}."""

_KINDS: dict[str, tuple[mujoco.mjtObj, str, str]] = {
    "body_": (mujoco.mjtObj.mjOBJ_BODY, "nbody", "body"),
    "jnt_": (mujoco.mjtObj.mjOBJ_JOINT, "njnt", "joint"),
    "dof_": (mujoco.mjtObj.mjOBJ_JOINT, "njnt", "joint"),
    "geom_": (mujoco.mjtObj.mjOBJ_GEOM, "ngeom", "geom"),
    "site_": (mujoco.mjtObj.mjOBJ_SITE, "nsite", "site"),
    "actuator_": (mujoco.mjtObj.mjOBJ_ACTUATOR, "nu", "actuator"),
    "tendon_": (mujoco.mjtObj.mjOBJ_TENDON, "ntendon", "tendon"),
    "pair_": (mujoco.mjtObj.mjOBJ_PAIR, "npair", "pair"),
    "eq_": (mujoco.mjtObj.mjOBJ_EQUALITY, "neq", "equality"),
}
"""Field prefix -> (object type, MjModel count attribute, element kind in messages)."""


OPTION = "opt"
"""The field name of MjModel.opt's settings: opt.o_friction = [...] (its elements are MjOption's
float fields)."""
OPTION_FIELDS = (
    "timestep", "impratio", "density", "viscosity", "gravity", "wind", "magnetic",
    "o_margin", "o_solref", "o_solimp", "o_friction",
)  # fmt: skip
"""MjOption's settings an override may set. Setting an o_ field turns on the contact override flag,
as MJCF's <option o_friction="..."><flag override="enable"/></option> does: every contact then takes
the o_ values."""


def _set_options(model: mujoco.MjModel, values: dict[str, np.ndarray]) -> None:
    for element, value in values.items():
        current = model_value(model, OPTION, element)
        current[: value.size] = value
        setattr(model.opt, element, current[0] if current.size == 1 else current)
        if element.startswith("o_"):
            model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_OVERRIDE


def settable_fields(model: mujoco.MjModel) -> list[str]:
    """The MjModel fields an override may set: float arrays with one row per element of a kind in
    `_KINDS`."""
    fields = []
    for name in dir(model):
        prefix = field_prefix(name)
        if prefix is None:
            continue
        value = getattr(model, name, None)
        count = _count(model, prefix)
        if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim >= 1:
            if value.shape[0] == count:
                fields.append(name)
    return sorted(fields)


def field_prefix(name: str) -> str | None:
    """The kind prefix of the MjModel field `name` ("body_", "dof_", ...), or None."""
    return next((prefix for prefix in _KINDS if name.startswith(prefix)), None)


def _count(model: mujoco.MjModel, prefix: str) -> int:
    return int(model.nv if prefix == "dof_" else getattr(model, _KINDS[prefix][1]))


def element_rows(model: mujoco.MjModel, field: str, element: str) -> np.ndarray:
    """The rows of `field` that `element` names: its id, or a joint's dofs for a dof_ field."""
    prefix = field_prefix(field)
    assert prefix is not None, "checked by the caller"
    obj_type, count_attr, kind = _KINDS[prefix]
    element_names = names(model, obj_type, int(getattr(model, count_attr)))
    if element not in element_names:
        err = UnknownNameError(kind, element, [n for n in element_names if n])
        err.args = (
            f"{field}.{element}: the model has no {kind} {element!r}; its {kind} names are: "
            f"{', '.join(err.valid)}",
        )
        raise err
    index = element_names.index(element)
    if prefix != "dof_":
        return np.array([index])
    start = int(model.jnt_dofadr[index])
    num = {0: 6, 1: 3}.get(int(model.jnt_type[index]), 1)  # free, ball, else one dof
    return np.arange(start, start + num)


def apply_model_overrides(model: mujoco.MjModel, overrides: ModelOverrides) -> None:
    """Set `overrides` (checked by `check_model_overrides`) on `model` in place: each value fills
    the leading entries of its element's rows (all of a joint's dofs, row after row, for a dof_
    field)."""
    for field, per_element in overrides.items():
        if field == OPTION:
            _set_options(model, per_element)
            continue
        array = getattr(model, field)
        for element, value in per_element.items():
            rows = element_rows(model, field, element)
            block = array[rows]  # a copy (fancy indexing)
            flat = block.reshape(-1)
            flat[: value.size] = value
            array[rows] = flat.reshape(block.shape)


def overridden(model: mujoco.MjModel, overrides: ModelOverrides) -> mujoco.MjModel:
    """A copy of `model` with `overrides` set; `model` itself is never changed."""
    new = copy.copy(model)  # MjModel's copy is a deep copy of its buffers
    apply_model_overrides(new, overrides)
    return new


def model_value(model: mujoco.MjModel, field: str, element: str) -> np.ndarray:
    """The flat values of `element`'s rows of `field` in `model`, (row size * rows,); for "opt", the
    option's."""
    if field == OPTION:
        if element not in OPTION_FIELDS:
            err = UnknownNameError("option", element, OPTION_FIELDS)
            err.args = (
                f"opt.{element}: MjOption has no float field {element!r}; its fields are: "
                f"{', '.join(err.valid)}",
            )
            raise err
        return np.atleast_1d(np.asarray(getattr(model.opt, element), dtype=float)).copy()
    return np.asarray(
        getattr(model, field)[element_rows(model, field, element)], dtype=float
    ).reshape(-1)


def toml_value(value: np.ndarray) -> Any:
    """`value` as TOML writes it back: a float for one entry, else a list of floats."""
    flat = [float(v) for v in np.asarray(value).reshape(-1)]
    return flat[0] if len(flat) == 1 else flat


def parse_override_entries(
    entries: list[str] | tuple[str, ...], flag: str = "--plant-overrides"
) -> ModelOverrides:
    """{field: {element: value}} from command-line entries "FIELD.ELEMENT=VALUE" (VALUE a number or
    a TOML list, e.g. "geom_friction.cube=[0.9, 0.005, 0.0001]"); ConfigError for an entry of
    another form. Names and shapes are checked later, against the task's model."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib

    parsed: ModelOverrides = {}
    for entry in entries:
        key, sep, text = entry.partition("=")
        field, dot, element = key.strip().partition(".")
        if not sep or not dot or not field or not element:
            raise ConfigError(
                f"{flag} takes FIELD.ELEMENT=VALUE entries (e.g. body_mass.pole=0.13), got "
                f"{entry!r}"
            )
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            raise ConfigError(
                f"{flag} {entry!r}: the value must be a number or a list like [0.9, 0.005]"
            ) from None
        parsed.setdefault(field, {})[element] = value
    return parsed


def override_task_models(task: "Task", planning: ModelOverrides, plant: ModelOverrides) -> "Task":
    """`task` with `planning` set on a copy of its planning model and `plant` on a copy of its plant
    model (each checked already); the models it was built with are never changed, so the plant stays
    the MJCF's where only the planning model is overridden."""
    if planning:
        task.model = overridden(task.model, planning)
        task.model_overrides = planning
    if plant:
        task.sim_model = overridden(task.sim_model, plant)
        task.plant_overrides = plant
    return task
