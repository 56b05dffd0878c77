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
row's leading entries. Every name and shape is checked against a model (`check_model_overrides`)
before anything is set, and so is the model they make: one MuJoCo can simulate (`check_simulable`: a
positive timestep, masses, inertias and sizes, MuJoCo compiler's rules for bodies, and a few steps
of MuJoCo itself from qpos0).
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
        prefix = _prefix(name)
        if prefix is None:
            continue
        value = getattr(model, name, None)
        count = _count(model, prefix)
        if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim >= 1:
            if value.shape[0] == count:
                fields.append(name)
    return sorted(fields)


def _prefix(name: str) -> str | None:
    return next((prefix for prefix in _KINDS if name.startswith(prefix)), None)


def _count(model: mujoco.MjModel, prefix: str) -> int:
    return int(model.nv if prefix == "dof_" else getattr(model, _KINDS[prefix][1]))


def _rows(model: mujoco.MjModel, field: str, element: str) -> np.ndarray:
    """The rows of `field` that `element` names: its id, or a joint's dofs for a dof_ field."""
    prefix = _prefix(field)
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


def check_model_overrides(
    model: mujoco.MjModel, overrides: Any, *, simulable: bool = True
) -> ModelOverrides:
    """`overrides` checked against `model`: {field: {element: value as a float array}}.

    Raises UnknownNameError (an unknown field or element, listing the valid names) or ConfigError (a
    value of the wrong shape or type, naming the expected shape; with `simulable`, a model MuJoCo
    cannot simulate, as `check_simulable` tells), each in one line. `simulable` False checks names
    and shapes alone (a FIELD.ELEMENT to fit, whose value is not known yet).
    """
    if not isinstance(overrides, dict):
        raise ConfigError(
            f"model overrides must be a table of FIELD.ELEMENT = value, got {overrides!r}"
        )
    valid = [*settable_fields(model), OPTION]
    checked: ModelOverrides = {}
    for field, per_element in overrides.items():
        if field not in valid:
            prefix = _prefix(field)
            choices = [name for name in valid if name.startswith(prefix)] if prefix else valid
            raise UnknownNameError("model field", field, choices)
        if not isinstance(per_element, dict):
            raise ConfigError(
                f"{field} needs an element name, as {field}.NAME = value; got {field} = "
                f"{per_element!r}"
            )
        checked[field] = {}
        for element, value in per_element.items():
            width = model_value(model, field, element).size
            try:
                array = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise ConfigError(
                    f"{field}.{element} must be a number or a list of at most {width} "
                    f"numbers, got {value!r}"
                ) from None
            if (
                array.ndim > 1
                or array.size > width
                or array.size == 0
                or not np.all(np.isfinite(array))
            ):
                raise ConfigError(
                    f"{field}.{element} must be a finite number or a list of at most {width} "
                    f"numbers, got {value!r}"
                )
            checked[field][element] = array.reshape(-1)
    if simulable and checked:
        check_simulable(model, checked)
    return checked


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
            rows = _rows(model, field, element)
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
    return np.asarray(getattr(model, field)[_rows(model, field, element)], dtype=float).reshape(-1)


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


NON_NEGATIVE_FIELDS = (
    "body_mass", "body_inertia", "dof_damping", "dof_armature", "dof_frictionloss", "jnt_stiffness",
    "geom_friction", "tendon_damping", "tendon_stiffness", "tendon_armature", "tendon_frictionloss",
)  # fmt: skip
"""Fields whose every entry is a physical magnitude, at least 0 (MuJoCo's compiler: "mass and
inertia cannot be negative"; a negative damping, armature or stiffness makes the implicit
integrator's mass matrix singular)."""
POSITIVE_OPTIONS = ("timestep", "impratio")
"""MjOption's fields that must be above 0: the step in seconds, and the ratio MuJoCo divides
friction's impedance by."""
NON_NEGATIVE_OPTIONS = ("density", "viscosity", "o_friction")
"""MjOption's fields that are at least 0: the medium's density and viscosity, and the override
friction."""
GEOM_SIZES = {
    mujoco.mjtGeom.mjGEOM_SPHERE: 1, mujoco.mjtGeom.mjGEOM_CAPSULE: 2, mujoco.mjtGeom.mjGEOM_CYLINDER: 2,  # noqa: E501
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: 3, mujoco.mjtGeom.mjGEOM_BOX: 3,
}  # fmt: skip
"""Geom type -> how many leading entries of geom_size MuJoCo's compiler requires positive ("size %d
must be positive in geom"); a plane's third entry, its grid spacing, too. A mesh's or height field's
size comes from its data."""
SIMULATED_STEPS = 10
"""Steps MuJoCo takes from qpos0, with zero controls, to tell an overridden model it cannot
simulate."""
_UNSTABLE = (
    mujoco.mjtWarning.mjWARN_INERTIA, mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
)  # fmt: skip
"""MuJoCo's warnings for a model it cannot simulate: a singular mass matrix, or a state that blew
up."""


def check_simulable(model: mujoco.MjModel, overrides: ModelOverrides) -> None:
    """Raise ConfigError (one line naming the entry, what MuJoCo needs and the value got) unless the
    model that `overrides` (checked names and shapes) make from `model` is one MuJoCo can simulate:
    every value within mjMAXVAL (1e10, beyond which MuJoCo takes a state as diverged); a positive
    timestep; the magnitudes of `NON_NEGATIVE_FIELDS` at least 0; MuJoCo compiler's rules for what
    it set (a moving body's mass and inertia at least mjMINVAL, principal inertias with A + B >= C,
    positive geom sizes, a joint range's lower end below its upper); and `SIMULATED_STEPS` of MuJoCo
    from qpos0 without a warning that `model` itself does not raise."""
    for field, per_element in overrides.items():
        for element, value in per_element.items():
            if np.any(np.abs(value) > mujoco.mjMAXVAL):
                raise ConfigError(
                    f"{field}.{element} must be within ±{mujoco.mjMAXVAL:g} (mjMAXVAL: "
                    "MuJoCo takes a magnitude beyond "
                    f"it as diverged), got {_shown(value)}"
                )
            positive = field == OPTION and element in POSITIVE_OPTIONS
            non_negative = field in NON_NEGATIVE_FIELDS or (
                field == OPTION and element in NON_NEGATIVE_OPTIONS
            )
            bad = value[value <= 0] if positive else value[value < 0] if non_negative else value[:0]
            if bad.size:
                need = "above 0" if positive else "at least 0"
                raise ConfigError(
                    f"{field}.{element} must be {need} for MuJoCo to simulate it, got "
                    f"{_shown(value)}"
                )
    new = overridden(model, overrides)
    if "body_mass" in overrides or "body_inertia" in overrides:
        _check_bodies(model, new)
    for element in overrides.get("geom_size", {}):
        _check_geom_size(new, element)
    for element in overrides.get("jnt_range", {}):
        index = int(_rows(new, "jnt_range", element)[0])
        low, high = new.jnt_range[index]
        if new.jnt_limited[index] and not low < high:
            raise ConfigError(
                f"jnt_range.{element} must have its lower end below its upper, as MuJoCo's "
                "compiler requires for a "
                f"limited joint, got {_shown(new.jnt_range[index])}"
            )
    before, after = _first_warning(model), _first_warning(new)
    if after is not None and (before is None or before[0] != after[0]):
        entries = ", ".join(
            f"{f}.{e} = {_shown(v)}" for f, values in overrides.items() for e, v in values.items()
        )
        text = mujoco.mju_warningText(*after).removesuffix(" Check model.").rstrip(".")
        raise ConfigError(
            f"{entries}: MuJoCo cannot simulate the model this makes: {text} (in "
            f"{SIMULATED_STEPS} steps from qpos0, "
            "where the model without it runs clean)"
        )


def _shown(value: np.ndarray) -> str:
    """`value` as the messages show it: 0.13, or [0.9, 0.005, 0.0001]."""
    flat = [f"{float(v):g}" for v in np.asarray(value).reshape(-1)]
    return flat[0] if len(flat) == 1 else "[" + ", ".join(flat) + "]"


def _check_bodies(model: mujoco.MjModel, new: mujoco.MjModel) -> None:
    """MuJoCo compiler's rules for a body's mass and principal inertia, on the bodies `new` breaks
    them for and `model` does not: A + B >= C for every order, and a moving body (one with joints)
    weighs at least mjMINVAL in mass and inertia, or has a static child body that does."""
    for body in range(1, new.nbody):
        name = new.body(body).name or f"#{body}"
        inertia = new.body_inertia[body]
        if min(_triangle(inertia)) < 0 <= min(_triangle(model.body_inertia[body])):
            raise ConfigError(
                f"body_inertia.{name} must be principal inertias of which any two add up to "
                "at least the third "
                f"(A + B >= C), as MuJoCo's compiler requires, got {_shown(inertia)}"
            )
        if _weightless(new, body) and not _weightless(model, body):
            raise ConfigError(
                f"body {name!r} moves, so MuJoCo's compiler requires its mass and inertia at "
                "least mjMINVAL = "
                f"{mujoco.mjMINVAL:g}; got body_mass.{name} = {new.body_mass[body]:g}, "
                f"body_inertia.{name} = {_shown(inertia)}"
            )


def _triangle(inertia: np.ndarray) -> tuple[float, float, float]:
    a, b, c = (float(x) for x in inertia)
    return a + b - c, a + c - b, b + c - a


def _weightless(model: mujoco.MjModel, body: int) -> bool:
    """Whether `body` moves (has joints) with a mass or inertia below mjMINVAL and no static child
    that has both, which MuJoCo's compiler refuses ("mass and inertia of moving bodies must be
    larger than mjMINVAL")."""

    def light(index: int) -> bool:
        return bool(
            model.body_mass[index] < mujoco.mjMINVAL
            or np.any(model.body_inertia[index] < mujoco.mjMINVAL)
        )

    if model.body_jntnum[body] == 0 or not light(body):
        return False
    children = np.flatnonzero((model.body_parentid == body) & (model.body_jntnum == 0))
    return all(light(int(child)) for child in children if child != body)


def _check_geom_size(model: mujoco.MjModel, element: str) -> None:
    index = int(_rows(model, "geom_size", element)[0])
    kind = mujoco.mjtGeom(int(model.geom_type[index]))
    size = model.geom_size[index]
    needed = [2] if kind == mujoco.mjtGeom.mjGEOM_PLANE else list(range(GEOM_SIZES.get(kind, 0)))
    if any(size[i] <= 0 for i in needed):
        entries = ", ".join(f"size[{i}]" for i in needed)
        raise ConfigError(
            f"geom_size.{element} must have {entries} above 0 for a {kind.name[7:].lower()} "
            "geom, as MuJoCo's "
            f"compiler requires, got {_shown(size)}"
        )


def _first_warning(model: mujoco.MjModel) -> tuple[int, int] | None:
    """(warning, info) of the first of `_UNSTABLE` MuJoCo raises in `SIMULATED_STEPS` from qpos0, or
    None."""
    data = mujoco.MjData(model)
    # MuJoCo prints a warning the first time only: counted from 1, none is printed
    for warning in _UNSTABLE:
        data.warning[warning].number = 1
    mujoco.mj_forward(model, data)
    for _ in range(SIMULATED_STEPS + 1):
        counts = {warning: data.warning[warning].number for warning in _UNSTABLE}
        # a count moved on, or MuJoCo reset the data on a
        if any(count != 1 for count in counts.values()):
            # diverged state: its counts went to 0, and the one it reset for was counted once again
            moved = [w for w, n in counts.items() if n > 1] or [
                w for w, n in counts.items() if n == 1
            ]
            warning = moved[0] if moved else mujoco.mjtWarning.mjWARN_BADQACC
            return int(warning), int(data.warning[warning].lastinfo)
        mujoco.mj_step(model, data)
    return None
