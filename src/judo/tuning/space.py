"""The search space of a tune: config fields with ranges, from the config dataclasses and their
@slider ranges.

A parameter is named `<kind>.<field>` with kind one of controller, optimizer, task:
`optimizer.temperature`, `controller.horizon`, `task.w_position`. By default the space holds every
numeric field of the optimizer's config that has a slider (noise_ramp only when use_noise_ramp is
on), plus `controller.horizon`, each over x/÷ 3 around the value in force (DEFAULT_SPREAD), clipped
to its slider range, and searched on a log scale so the value in force is the middle (the whole
slider range when the value is not positive). A range given in --params, or a field's slider range,
is searched on a log scale when it spans two decades or more (max / min >= 100, min > 0); int fields
stay ints.
"""

import math
import typing
from dataclasses import dataclass, fields
from typing import Any, Literal

from judo.core.configuration.config import MAX_MAGNITUDE, Config, coerce_field_value, field_types
from judo.core.configuration.config_values import (
    SearchSpaceError,
    controller_config_of,
    optimizer_config_of,
    split_name,
)
from judo.core.configuration.fields import slider_ranges
from judo.core.configuration.registry import CONFIG_KINDS, ConfigKind, default_configs
from judo.core.errors import ConfigError
from judo.core.spline import MIN_KNOTS

Kind = ConfigKind
KINDS = CONFIG_KINDS
DEFAULT_CONTROLLER_PARAMS = ("horizon",)
"""Controller fields searched by default, besides the optimizer's numeric fields (num_nodes among
them)."""
LOG_SCALE_RATIO = 100.0
"""A range with max / min at least this (two decades) is searched on a log scale."""
DEFAULT_SPREAD = 3.0
"""The default space searches each field from its value in force / this to its value x this."""


@dataclass(frozen=True)
class Param:
    """One searched config field.

    Attributes:
        kind: which config holds it: controller, optimizer or task.
        field: the field's name in that config.
        low, high: the range (inclusive); unused for a categorical parameter.
        log: search on a log scale.
        integer: an int field, sampled as an int.
        choices: the values of a categorical (Literal) field, else ().
    """

    kind: Kind
    field: str
    low: float = 0.0
    high: float = 0.0
    log: bool = False
    integer: bool = False
    choices: tuple[Any, ...] = ()

    @property
    def name(self) -> str:
        """`kind.field`, as on the command line and in Optuna."""
        return f"{self.kind}.{self.field}"


def numeric_fields(config_cls: type) -> list[str]:
    """The int and float fields of `config_cls`, in declaration order."""
    types = field_types(config_cls)
    return [f.name for f in fields(config_cls) if types[f.name] in (int, float)]


def make_param(
    kind: Kind,
    field: str,
    config: Config,
    bounds: tuple[float, float] | None = None,
    log: bool | None = None,
) -> Param:
    """The Param for `field` of `config`, over `bounds` or its @slider range; SearchSpaceError if it
    has neither.

    `log` None: a log scale when the range spans two decades or more (LOG_SCALE_RATIO)."""
    hint = field_types(type(config))[field]
    name = f"{kind}.{field}"
    if typing.get_origin(hint) is Literal:
        return Param(kind, field, choices=typing.get_args(hint))
    if hint is bool:
        return Param(kind, field, choices=(False, True))
    if hint not in (int, float):
        raise SearchSpaceError(
            f"{name} is a {getattr(hint, '__name__', hint)} field; only numbers can be searched"
        )
    if bounds is None:
        sliders = slider_ranges(type(config))
        if field not in sliders:
            raise SearchSpaceError(f"{name} has no @slider range; give one as {name}=LOW:HIGH")
        bounds = (sliders[field].min, sliders[field].max)
    low, high = bounds
    if not low < high:
        raise SearchSpaceError(
            f"{name}: the range's low ({low:g}) must be below its high ({high:g})"
        )
    integer = hint is int
    if integer:
        low, high = math.ceil(low), math.floor(high)
    if log is None:
        log = low > 0 and high / low >= LOG_SCALE_RATIO
    return Param(kind, field, float(low), float(high), log and low > 0, integer)


def around_value(kind: Kind, field: str, config: Config) -> Param:
    """The default Param of a field with a slider: ×/÷ DEFAULT_SPREAD around its value in `config`,
    clipped to the slider range, on a log scale; the slider range (by the usual rule) when the value
    is not positive or the clipped range is empty."""
    slider_range = slider_ranges(type(config))[field]
    value = float(getattr(config, field))
    if value > 0 and math.isfinite(value):
        low, high = (
            max(slider_range.min, value / DEFAULT_SPREAD),
            min(slider_range.max, value * DEFAULT_SPREAD),
        )
        if field_types(type(config))[field] is int:
            low, high = math.ceil(low), math.floor(high)
        if low < high:
            return make_param(kind, field, config, (low, high), log=True)
    return make_param(kind, field, config)


def parse_param_entry(entry: str) -> tuple[str, tuple[float, float] | None]:
    """`kind.field` or `kind.field=LOW:HIGH` -> (name, bounds or None)."""
    name, has_range, bounds = entry.partition("=")
    if not has_range:
        return name, None
    low, colon, high = bounds.partition(":")
    try:
        if not colon:
            raise ValueError
        lowest, highest = float(low), float(high)
    except ValueError:
        raise SearchSpaceError(
            f"--params {entry[:200]!r}: expected {name}=LOW:HIGH, e.g. {name}=0.01:1"
        ) from None
    if not all(math.isfinite(v) and abs(v) <= MAX_MAGNITUDE for v in (lowest, highest)):
        raise SearchSpaceError(
            f"--params {entry[:200]!r}: LOW and HIGH must be finite numbers of magnitude at "
            f"most {MAX_MAGNITUDE:g}"
        )
    return name, (lowest, highest)


def parse_fixed(
    entries: list[str] | tuple[str, ...], configs: dict[Kind, Config]
) -> dict[str, Any]:
    """`kind.field=value` entries (from --fix) -> {name: value checked against the field's type}."""
    fixed: dict[str, Any] = {}
    for entry in entries:
        name, has_value, text = entry.partition("=")
        if not has_value:
            raise SearchSpaceError(
                f"--fix {entry!r}: expected <kind>.<field>=VALUE, e.g. optimizer.num_rollouts=64"
            )
        kind, field = split_name(name, configs)
        try:
            fixed[name] = coerce_field_value(configs[kind], field, parse_value(text))
        except ConfigError as err:
            raise SearchSpaceError(f"--fix {entry!r}: {err}") from None
    return fixed


def parse_value(text: str) -> Any:
    """A number, true / false, or the string itself."""
    lowered = text.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return text.strip()


def build_space(
    task_name: str,
    optimizer_name: str,
    params: list[str] | tuple[str, ...] = (),
    fixed: dict[str, Any] | None = None,
) -> list[Param]:
    """The parameters to search for the pair.

    Args:
        params: `kind.field` or `kind.field=LOW:HIGH` entries (a bare name: its whole slider range);
            empty means the default space (every numeric optimizer field with a slider, plus
            controller.horizon, ×/÷ 3 around the value in force; see `around_value`).
        fixed: parsed --fix values; these are left out of the space.
    Raises SearchSpaceError for an unknown field (listing the valid ones) or one without a range.
    """
    configs = default_configs(task_name, optimizer_name)
    fixed = fixed or {}
    around = not params
    if params:
        entries = [parse_param_entry(entry) for entry in params]
    else:
        optimizer_cls = type(configs["optimizer"])
        sliders = slider_ranges(optimizer_cls)
        ramped = fixed.get("optimizer.use_noise_ramp", optimizer_config_of(configs).use_noise_ramp)
        entries = [
            (f"optimizer.{name}", None)
            for name in numeric_fields(optimizer_cls)
            if name in sliders and (name != "noise_ramp" or ramped)
        ]
        entries += [(f"controller.{name}", None) for name in DEFAULT_CONTROLLER_PARAMS]
    space = []
    for name, bounds in entries:
        if name in fixed:
            continue
        kind, field = split_name(name, configs)
        space.append(
            around_value(kind, field, configs[kind])
            if around
            else make_param(kind, field, configs[kind], bounds)
        )
    return fit_num_nodes(space, configs, fixed)


def fit_num_nodes(
    space: list[Param], configs: dict[Kind, Config], fixed: dict[str, Any]
) -> list[Param]:
    """Raise num_nodes' low end to what the spline order needs, unless the order itself is
    searched."""
    names = {param.name for param in space}
    if "optimizer.num_nodes" not in names or "controller.spline_order" in names:
        return space
    order = fixed.get("controller.spline_order", controller_config_of(configs).spline_order)
    needed = MIN_KNOTS[order]
    return [
        Param(p.kind, p.field, max(p.low, needed), p.high, p.log, p.integer)
        if p.name == "optimizer.num_nodes"
        else p
        for p in space
    ]
