"""Model overrides checked against a model before anything is set: names, shapes and values
(`check_model_overrides`), and the model they make, one MuJoCo can simulate (`check_simulable`: a
positive timestep, masses, inertias and sizes, MuJoCo compiler's rules for bodies, and a few steps
of MuJoCo itself from qpos0). The overrides themselves: judo.core.configuration.model_overrides.
"""

from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.model_overrides import (
    OPTION,
    ModelOverrides,
    element_rows,
    field_prefix,
    model_value,
    overridden,
    settable_fields,
)
from judo.core.errors import ConfigError, UnknownNameError


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
            prefix = field_prefix(field)
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
        index = int(element_rows(new, "jnt_range", element)[0])
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
    index = int(element_rows(model, "geom_size", element)[0])
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
