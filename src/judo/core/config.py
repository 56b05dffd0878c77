"""The config base class and the one place where a config field is set from outside (file, CLI, GUI)."""

import copy
import functools
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
        """Raise ConfigError if a field is out of range. Subclasses extend this and call super()."""


def require(condition: bool, message: str) -> None:
    """Raise ConfigError(message) unless `condition` holds; the one-line form of a config check."""
    if not condition:
        raise ConfigError(message)


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
        require(is_number and float(value).is_integer(), f"{where} expects an integer, got {value!r}")
        return int(value)
    if hint is float:
        require(is_number, f"{where} expects a number, got {value!r}")
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
