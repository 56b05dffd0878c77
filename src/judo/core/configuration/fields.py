"""Metadata for config fields: slider ranges and named 1-D arrays. The GUI reads it; nothing else
does.

Both helpers only attach metadata, so a config stays a plain dataclass that tyro and user code can
use directly.
"""

import difflib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, TypeVar

import numpy as np

ClassT = TypeVar("ClassT", bound=type)

SLIDER_ATTR = "__judo_sliders__"


LOG_SCALE_DECADES = 2.0
"""A float slider whose positive range spans at least this many powers of ten moves over log10."""


@dataclass(frozen=True)
class SliderRange:
    """The range of a numeric config field's slider; `step=None` lets the GUI choose.

    `log=None` puts a float slider on a log scale when `min > 0` and its range spans at least
    LOG_SCALE_DECADES (MPPI's temperature, 0.001 to 10); True or False decides it outright.
    """

    min: float
    max: float
    step: float | None = None
    log: bool | None = None

    @property
    def is_log(self) -> bool:
        """True when the slider moves over log10 of the value."""
        if self.log is not None:
            return self.log and self.min > 0
        return self.min > 0 and self.max / self.min >= 10.0**LOG_SCALE_DECADES


@dataclass(frozen=True)
class ArrayFieldSpec:
    """GUI metadata for a 1-D array field: one slider per entry, optionally a marker in the
    scene."""

    names: tuple[str, ...]
    mins: tuple[float, ...]
    maxs: tuple[float, ...]
    steps: tuple[float, ...]
    vis_name: str | None = None


def slider(
    field_name: str, min: float, max: float, step: float | None = None, log: bool | None = None
) -> Callable[[ClassT], ClassT]:
    """Class decorator that gives the numeric field `field_name` a slider from `min` to `max`.

    Stack it above `@dataclass`, once per field (below it works too). `log` puts a float field's
    slider on a log scale (None: when the range spans two or more decades, see `SliderRange`).
    Raises ConfigError for an inverted range, and, when the class is defined, for a `field_name`
    that is not one of its fields (a typo would otherwise give no slider and no error), listing the
    fields.
    """
    from judo.core.errors import ConfigError

    if not min < max:
        raise ConfigError(f"slider for {field_name!r}: min ({min}) must be below max ({max})")
    if step is not None and step <= 0:
        raise ConfigError(f"slider for {field_name!r}: step must be positive, got {step}")

    def decorate(cls: ClassT) -> ClassT:
        names = field_names(cls)
        if field_name not in names:
            close = difflib.get_close_matches(field_name, names, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ConfigError(
                f"@slider({field_name!r}, ...) on {cls.__name__}: {cls.__name__} has no "
                f"field {field_name!r}{hint}; "
                f"expected one of its fields: {', '.join(names) or '(none)'}"
            )
        inherited = dict(getattr(cls, SLIDER_ATTR, {}))
        inherited[field_name] = SliderRange(
            float(min), float(max), None if step is None else float(step), log
        )
        setattr(cls, SLIDER_ATTR, inherited)
        return cls

    return decorate


def field_names(cls: type) -> list[str]:
    """The fields of config class `cls` and its bases, in definition order: the annotated class
    attributes (ClassVars left out), which are its dataclass fields, and are known before
    `@dataclass` has run too."""
    names: dict[str, None] = {}
    for klass in reversed(cls.__mro__):
        for name, annotation in klass.__dict__.get("__annotations__", {}).items():
            if not str(annotation).startswith(("ClassVar", "typing.ClassVar")):
                names[name] = None
    return list(names)


def slider_ranges(config_cls: type) -> dict[str, SliderRange]:
    """The `@slider` ranges declared on `config_cls` and its bases, by field name."""
    return dict(getattr(config_cls, SLIDER_ATTR, {}))


def np_1d_field(
    array: np.ndarray | Sequence[float],
    names: Sequence[str] | None = None,
    mins: Sequence[float] | None = None,
    maxs: Sequence[float] | None = None,
    steps: Sequence[float] | None = None,
    vis_name: str | None = None,
) -> Any:
    """A dataclass field holding a 1-D float array of length n, shown in the GUI as n sliders.

    Each instance gets its own copy of `array`. Omitted names default to "0", "1", ...; omitted
    ranges default to +-(2 |value| + 1) around zero, step 0.01. With `vis_name`, the GUI also draws
    the first three entries as a point in the scene under that name.
    """
    from judo.core.errors import ConfigError

    default = np.asarray(array, dtype=float)
    if default.ndim != 1:
        raise ConfigError(f"np_1d_field needs a 1-D array, got shape {default.shape}")
    n = len(default)
    spans = 2.0 * np.abs(default) + 1.0

    def fill(values: Sequence[Any] | None, fallback: Sequence[Any], label: str) -> tuple[Any, ...]:
        values = fallback if values is None else values
        if len(values) != n:
            raise ConfigError(f"np_1d_field: {label} has {len(values)} entries, the array has {n}")
        return tuple(values)

    spec = ArrayFieldSpec(
        names=fill(names, [str(i) for i in range(n)], "names"),
        mins=fill(mins, list(-spans), "mins"),
        maxs=fill(maxs, list(spans), "maxs"),
        steps=fill(steps, [0.01] * n, "steps"),
        vis_name=vis_name,
    )
    return field(default_factory=lambda: default.copy(), metadata={"judo_array": spec})


def array_field_spec(config_cls: type, field_name: str) -> ArrayFieldSpec | None:
    """The np_1d_field metadata of `field_name` on `config_cls`, or None if it has none."""
    for f in fields(config_cls):
        if f.name == field_name:
            return f.metadata.get("judo_array")
    return None
