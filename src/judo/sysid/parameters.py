"""The parameters a sysid fit names (judo.sysid.fit): `--params` entries parsed into FitParameters,
the actuation delay among them, and their values set in a model's rows.
"""

import re
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import model_value, overridden
from judo.core.errors import ConfigError

DELAY = "delay"
"""The field of the FitParameter that stands for the actuation delay (--fit-delay), in seconds, of
every actuator."""


@dataclass(frozen=True)
class FitParameter:
    """One parameter to fit: entry `index` of `element`'s row of the MjModel `field` (None: the
    row's one value), or, `whole`, one factor scaling all of its row (a heavier part of the same
    shape: its inertia's row)."""

    field: str
    element: str
    index: int | None = None
    whole: bool = False

    @property
    def name(self) -> str:
        """How the command line and the report name it: "body_mass.pole" or "geom_friction.cube[0]";
        "delay" for the actuation delay."""
        if self.field == DELAY:
            return DELAY
        return f"{self.field}.{self.element}" + ("" if self.index is None else f"[{self.index}]")

    @property
    def key(self) -> tuple[str, str, int]:
        """(field, element, index) as judo.sysid.quality names parameters: index -1 for a whole
        row."""
        return (self.field, self.element, -1 if self.whole else self.index or 0)


DELAY_PARAMETER = FitParameter(DELAY, "actuators")
"""The actuation delay (s) of every actuator, fitted with --fit-delay: each logged action takes
effect that late."""


def parse_parameters(
    texts: list[str] | tuple[str, ...], model: mujoco.MjModel
) -> list[FitParameter]:
    """`--params` entries ("FIELD.ELEMENT[i]": one entry of a row; "FIELD.ELEMENT": the row's one
    value, or a factor scaling all of a longer row) checked against `model`: UnknownNameError for an
    unknown field or element (listing the valid names), ConfigError for another form, an index out
    of range, a row named twice, or a whole row that a factor cannot fit (a position or orientation,
    or all 0: listing its entries)."""
    parameters: list[FitParameter] = []
    for text in texts:
        match = re.fullmatch(r"([a-z0-9_]+)\.([^\[\]]+)(?:\[(\d+)\])?", text)
        if match is None:
            raise ConfigError(
                "--params takes FIELD.ELEMENT or FIELD.ELEMENT[i] (e.g. body_mass.pole), got "
                f"{text!r}"
            )
        field, element, index = match.group(1), match.group(2), match.group(3)
        # the field and element exist
        check_model_overrides(model, {field: {element: 0.0}}, simulable=False)
        current = model_value(model, field, element)
        if index is not None and int(index) >= current.size:
            raise ConfigError(
                f"--params {text}: {field}.{element} has {current.size} entries, index 0 to "
                f"{current.size - 1}"
            )
        whole = index is None and current.size > 1
        if whole and (field.endswith(("pos", "quat")) or not np.any(current)):
            valid = ", ".join(f"{text}[{i}]" for i in range(current.size))
            why = "a position or orientation" if field.endswith(("pos", "quat")) else "all 0"
            raise ConfigError(
                f"--params {text}: its {current.size} entries {current.tolist()} are {why}, "
                "which no factor fits; "
                f"name the entries to fit: {valid}"
            )
        parameter = FitParameter(field, element, None if index is None else int(index), whole)
        row = parameter.key[:2]
        named = {p.key for p in parameters}
        if parameter.key in named or row in {p.key[:2] for p in parameters if p.whole or whole}:
            raise ConfigError(f"--params {text}: the same entries are named twice; name each once")
        parameters.append(parameter)
    if not parameters:
        raise ConfigError("--params needs at least one FIELD.ELEMENT to fit, e.g. body_mass.pole")
    return parameters


def delay_fits_model(model: mujoco.MjModel, delay: float) -> bool:
    """Whether every actuator of `model` keeps enough action history (MJCF's nsample, compiled in)
    for MuJoCo's actuator_delay to hold `delay` seconds: without it MuJoCo ignores
    actuator_delay."""
    needed = int(np.ceil(delay / float(model.opt.timestep) - 1e-9)) + 1
    return model.nu > 0 and bool(np.all(model.actuator_history[:, 0] >= needed))


def parameter_rows(
    model: mujoco.MjModel, values: list[tuple[FitParameter, float]]
) -> dict[str, dict[str, Any]]:
    """{field: {element: row}}: each parameter's value set in its row of `model` (the rest of the
    row as it is), or for a whole row, the row scaled by it."""
    rows: dict[tuple[str, str], np.ndarray] = {}
    for parameter, value in values:
        if parameter.field == DELAY:  # a delay of the actions, not of the model
            continue
        key = (parameter.field, parameter.element)
        row = rows.setdefault(key, model_value(model, *key).copy())
        if parameter.whole:
            row *= value
        else:
            row[parameter.index or 0] = value
    overrides: dict[str, dict[str, Any]] = {}
    for (field, element), row in rows.items():
        overrides.setdefault(field, {})[element] = row
    return overrides


def fitted_model(
    model: mujoco.MjModel, parameters: list[FitParameter], values: np.ndarray
) -> mujoco.MjModel:
    """A copy of `model` with each parameter set to its value in `values` (P,)."""
    return overridden(model, parameter_rows(model, list(zip(parameters, values, strict=True))))
