"""The config base class and the one place where a config field is set from outside (file, CLI,
GUI)."""

import copy
import copyreg
import functools
import math
import typing
from dataclasses import dataclass, fields
from typing import Any, Literal, TypeVar

import numpy as np

from judo.core.errors import ConfigError, UnknownNameError

MAX_MAGNITUDE = 1e9
"""Largest magnitude of a float config value (a weight, a noise scale, a goal): far beyond any that
plans, below MuJoCo's "huge value" mark (1e10), and small enough that a reward squaring it and
summing it over every rollout and step never overflows."""
MAX_INT = 2**53
"""Largest magnitude of an integer config value: every one is exact as a float, a numpy int and in a
browser."""
SHOWN = 200
"""Characters of an offending value a message shows at most."""


def shown(value: Any) -> str:
    """`repr(value)`, cut to SHOWN characters, for an error message (a 50 MB value is never echoed
    whole)."""
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return text if len(text) <= SHOWN else f"{text[:SHOWN]}... ({len(text)} characters)"


@dataclass
class Config:
    """Base of every judo config: a plain dataclass checked on construction and by `validate()`."""

    def __post_init__(self) -> None:
        self.validate()
        check_magnitudes(self)

    def validate(self) -> None:
        """Raise ConfigError if a field is out of range. Subclasses extend this and call super().

        The base check refuses NaN and infinite values in every float and array field: no planner
        or reward works with them, and a NaN that reaches MuJoCo floods the log.
        """
        for f in fields(self):
            value = getattr(self, f.name, None)
            where = f"{type(self).__name__}.{f.name}"
            if isinstance(value, (float, np.floating)):
                require(math.isfinite(value), f"{where} must be a finite number, got {value}")
            if isinstance(value, np.ndarray) and value.dtype.kind in "fc":
                require(
                    bool(np.isfinite(value).all()),
                    f"{where} must hold finite numbers, got {shown(value)}",
                )


ConfigT = TypeVar("ConfigT", bound=Config)
"""A config class, kept by the helpers that copy or build one (`with_updates`, `snapshot`,
`make_config`)."""


def check_magnitudes(config: Config) -> None:
    """Raise ConfigError for a value no field may hold whatever its own range, one check per kind of
    field: a float (or an array's entry) beyond MAX_MAGNITUDE, an integer beyond MAX_INT. A weight,
    noise scale or goal of 1e308 passes "finite" but overflows every planning cycle.

    Run after `validate()`, at construction and by `with_updates`, so a field's own range is named
    first.
    """
    for f in fields(config):
        value = getattr(config, f.name, None)
        where = f"{type(config).__name__}.{f.name}"
        if isinstance(value, (float, np.floating)):
            require(
                abs(value) <= MAX_MAGNITUDE,
                f"{where} must be of magnitude at most {MAX_MAGNITUDE:g}, got {value}",
            )
        if isinstance(value, np.ndarray) and value.dtype.kind in "fc":
            require(
                bool((np.abs(value) <= MAX_MAGNITUDE).all()),
                f"{where} must hold numbers of magnitude at most {MAX_MAGNITUDE:g}, got "
                f"{shown(value)}",
            )
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            require(
                abs(int(value)) <= MAX_INT,
                f"{where} must be of magnitude at most 2**53, got {shown(value)}",
            )


def require(condition: bool, message: str) -> None:
    """Raise ConfigError(message) unless `condition` holds; the one-line form of a config check."""
    if not condition:
        raise ConfigError(message)


def check_seed(seed: int | None) -> None:
    """Raise ConfigError unless `seed` is None or an integer from 0 to 2**63 - 1 (what numpy's
    generators take)."""
    if seed is None:
        return
    integral = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)
    require(
        integral and 0 <= int(seed) < 2**63,
        f"seed must be an integer from 0 to 2**63 - 1, got {seed!r}",
    )


def require_between(
    name: str, value: float, low: float, high: float, unit: str = "", *, above: bool = False
) -> None:
    """Raise ConfigError unless low <= value <= high (low < value with `above`), naming the valid
    range.

    The message reads e.g. "horizon must be above 0 and at most 60 s, got inf".
    """
    ok = (value > low if above else value >= low) and value <= high
    if not ok:
        lower = f"above {low} and at most" if above else f"between {low} and"
        raise ConfigError(f"{name} must be {lower} {high}{unit}, got {value}")


@functools.cache
def field_types(config_cls: type) -> dict[str, Any]:
    """The resolved type hint of every dataclass field of `config_cls`, by name."""
    hints = typing.get_type_hints(config_cls)
    return {f.name: hints[f.name] for f in fields(config_cls)}


def coerce_field_value(config: Config, name: str, value: Any) -> Any:
    """`value` converted to the type of field `name` of `config`, or a ConfigError saying why not.

    Ints are accepted for floats, integral floats for ints, lists for 1-D arrays of the same length.
    """
    types = field_types(type(config))
    if name not in types:
        raise UnknownNameError(f"field of {type(config).__name__}", name, types)
    hint = types[name]
    where = f"{type(config).__name__}.{name}"
    if hint is bool:
        require(
            isinstance(value, (bool, np.bool_)),
            f"{where} expects true or false, got {shown(value)}",
        )
        return bool(value)
    is_number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, bool
    )
    if hint is int:
        integral = isinstance(value, (int, np.integer)) or (is_number and float(value).is_integer())
        require(is_number and integral, f"{where} expects an integer, got {shown(value)}")
        return int(value)
    if hint is float:
        require(is_number, f"{where} expects a number, got {shown(value)}")
        try:
            number = float(value)
        except OverflowError:  # an int beyond a float's range (10**400)
            number = math.inf
        require(math.isfinite(number), f"{where} expects a finite number, got {shown(value)}")
        return number
    if hint is str:
        require(isinstance(value, str), f"{where} expects a string, got {shown(value)}")
        return value
    if typing.get_origin(hint) is Literal:
        choices = typing.get_args(hint)
        # an array compares elementwise
        scalar = isinstance(value, (str, int, float, bool, np.generic))
        require(
            scalar and value in choices,
            f"{where} expects one of {list(choices)}, got {shown(value)}",
        )
        return value
    if hint is np.ndarray:
        current = getattr(config, name)
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(
                f"{where} expects a list of {len(current)} numbers, got {shown(value)}"
            ) from None
        except OverflowError:  # an int beyond a float's range
            raise ConfigError(
                f"{where} expects {len(current)} finite numbers, got {shown(value)}"
            ) from None
        require(
            array.shape == current.shape,
            f"{where} expects {len(current)} numbers, got {shown(value)}",
        )
        require(
            bool(np.isfinite(array).all()),
            f"{where} expects {len(current)} finite numbers, got {shown(value)}",
        )
        return array
    return value


def with_updates(config: ConfigT, updates: dict[str, Any]) -> ConfigT:
    """A validated copy of `config` with `updates` applied; `config` itself is never changed.

    Raises UnknownNameError for a field that does not exist and ConfigError for a bad value, so a
    caller (override file, CLI, GUI) can refuse the edit and keep the previous config.
    """
    if not isinstance(updates, dict):
        raise ConfigError(
            f"updates must be a dict {{field: value}}, got {type(updates).__name__} "
            f"{shown(updates)}"
        )
    updated = snapshot(config)
    for name, value in updates.items():
        setattr(updated, name, coerce_field_value(updated, name, value))
    updated.validate()
    check_magnitudes(updated)
    return updated


def snapshot(config: ConfigT) -> ConfigT:
    """A copy of `config` that later edits of the original cannot reach (arrays are copied too)."""
    if _copies_its_dict(type(config)):  # what copy.copy does for such a class, without its lookups
        copied = object.__new__(type(config))
        copied.__dict__.update(config.__dict__)
    else:
        copied = copy.copy(config)
    for name, value in vars(copied).items():
        if isinstance(value, np.ndarray):
            setattr(copied, name, value.copy())
    return copied


@functools.cache
def _copies_its_dict(cls: type) -> bool:
    """Whether copy.copy of a `cls` instance is a new instance whose __dict__ is updated from the
    original's: a plain class (a dataclass config) that defines none of the hooks that change
    copying, nor slots."""
    hooks = ("__copy__", "__setstate__", "__getnewargs__", "__getnewargs_ex__", "__slots__")
    return (
        cls.__new__ is object.__new__
        and cls.__reduce_ex__ is object.__reduce_ex__
        and cls.__reduce__ is object.__reduce__
        and getattr(cls, "__getstate__", None) in (None, getattr(object, "__getstate__", None))
        and not any(hasattr(cls, hook) for hook in hooks)
        and cls not in copyreg.dispatch_table
    )
