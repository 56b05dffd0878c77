"""The config base class and the one place where a config field is set from outside (file, CLI, GUI)."""

import copy
import functools
import math
import typing
from dataclasses import dataclass, fields
from typing import Any, Literal

import numpy as np

from judo.core.errors import ConfigError, UnknownNameError


@dataclass
class Config:
    """Base of every judo config: a plain dataclass checked on construction and by `validate()`."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ConfigError if a field is out of range. Subclasses extend this and call super().

        The base check refuses NaN and infinite values in every float and array field: no planner
        or reward works with them, and a NaN that reaches MuJoCo floods the log.
        """
        for f in fields(self):
            value = getattr(self, f.name, None)
            if isinstance(value, (float, np.floating)) and not math.isfinite(value):
                raise ConfigError(f"{type(self).__name__}.{f.name} must be a finite number, got {value}")
            if isinstance(value, np.ndarray) and value.dtype.kind in "fc" and not np.isfinite(value).all():
                raise ConfigError(f"{type(self).__name__}.{f.name} must hold finite numbers, got {value.tolist()}")


def require(condition: bool, message: str) -> None:
    """Raise ConfigError(message) unless `condition` holds; the one-line form of a config check."""
    if not condition:
        raise ConfigError(message)


def check_seed(seed: int | None) -> None:
    """Raise ConfigError unless `seed` is None or an integer from 0 to 2**63 - 1 (what numpy's generators take)."""
    if seed is None:
        return
    integral = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)
    require(integral and 0 <= int(seed) < 2**63, f"seed must be an integer from 0 to 2**63 - 1, got {seed!r}")


def require_between(name: str, value: float, low: float, high: float, unit: str = "", *, above: bool = False) -> None:
    """Raise ConfigError unless low <= value <= high (low < value with `above`), naming the valid range.

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
        require(isinstance(value, (bool, np.bool_)), f"{where} expects true or false, got {value!r}")
        return bool(value)
    is_number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if hint is int:
        integral = isinstance(value, (int, np.integer)) or (is_number and float(value).is_integer())
        require(is_number and integral, f"{where} expects an integer, got {value!r}")
        return int(value)
    if hint is float:
        require(is_number, f"{where} expects a number, got {value!r}")
        require(math.isfinite(value), f"{where} expects a finite number, got {value!r}")
        return float(value)
    if hint is str:
        require(isinstance(value, str), f"{where} expects a string, got {value!r}")
        return value
    if typing.get_origin(hint) is Literal:
        choices = typing.get_args(hint)
        require(value in choices, f"{where} expects one of {list(choices)}, got {value!r}")
        return value
    if hint is np.ndarray:
        current = getattr(config, name)
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"{where} expects a list of {len(current)} numbers, got {value!r}") from None
        require(array.shape == current.shape, f"{where} expects {len(current)} numbers, got {value!r}")
        require(bool(np.isfinite(array).all()), f"{where} expects {len(current)} finite numbers, got {value!r}")
        return array
    return value


def with_updates(config: Config, updates: dict[str, Any]) -> Config:
    """A validated copy of `config` with `updates` applied; `config` itself is never changed.

    Raises UnknownNameError for a field that does not exist and ConfigError for a bad value, so a
    caller (override file, CLI, GUI) can refuse the edit and keep the previous config.
    """
    updated = snapshot(config)
    for name, value in updates.items():
        setattr(updated, name, coerce_field_value(updated, name, value))
    updated.validate()
    return updated


def snapshot(config: Config) -> Config:
    """A copy of `config` that later edits of the original cannot reach (arrays are copied too)."""
    copied = copy.copy(config)
    for name, value in vars(copied).items():
        if isinstance(value, np.ndarray):
            setattr(copied, name, value.copy())
    return copied
