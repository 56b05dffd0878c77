"""Config fields named `kind.field` (controller.horizon, optimizer.sigma, task.w_position): look one
up in a pair's configs, and apply values given by such names.

evaluate, collect and tune's trials apply the fields changed on a command line (or a trial's values)
through `apply_values`; tune's search space (judo.tuning.space) names its parameters the same way.
"""

import typing
from collections.abc import Mapping
from typing import Any, Literal, TypeVar, cast

from judo.core.configuration.config import Config, field_types, with_updates
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import ConfigKind
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig

KindT = TypeVar("KindT", bound=str)
"""The keys of a configs dict: judo.core.configuration.registry.ConfigKind, or str where the kinds
are not known statically."""


class SearchSpaceError(JudoError):
    """A `kind.field` name (an episode's changed field, a tune --params or --fix entry) that names
    no config field, or a tune entry that has no range or cannot be parsed."""


def valid_names(configs: Mapping[KindT, Config]) -> list[str]:
    """Every `kind.field` a tune can search or fix: numeric and Literal fields of the three
    configs."""
    names = []
    for kind, config in configs.items():
        types = field_types(type(config))
        names += [
            f"{kind}.{name}"
            for name, hint in types.items()
            if hint in (int, float, bool) or typing.get_origin(hint) is Literal
        ]
    return names


def split_name(name: str, configs: Mapping[KindT, Config]) -> tuple[KindT, str]:
    """(kind, field) of `kind.field`; SearchSpaceError listing the valid names when there is no such
    field."""
    prefix, _, field = name.partition(".")
    for kind, config in configs.items():  # the key equal to `prefix`, typed as a key of `configs`
        if kind == prefix and field in field_types(type(config)):
            return kind, field
    raise SearchSpaceError(
        f"unknown parameter {name!r}: expected <controller|optimizer|task>.<field>; valid "
        "parameters are: " + ", ".join(valid_names(configs))
    )


def apply_values(configs: Mapping[KindT, Config], values: dict[str, Any]) -> dict[KindT, Config]:
    """New configs with `values` ({`kind.field`: value}) applied; ConfigError if they do not fit
    together."""
    updates: dict[KindT, dict[str, Any]] = {kind: {} for kind in configs}
    for name, value in values.items():
        kind, field = split_name(name, configs)
        updates[kind][field] = value
    return {kind: with_updates(config, updates[kind]) for kind, config in configs.items()}


def controller_config_of(configs: Mapping[ConfigKind, Config]) -> ControllerConfig:
    """configs["controller"] as the ControllerConfig it is (default_configs and configs_in_force put
    one there)."""
    return cast(ControllerConfig, configs["controller"])


def optimizer_config_of(configs: Mapping[ConfigKind, Config]) -> OptimizerConfig:
    """configs["optimizer"] as the OptimizerConfig it is (the optimizer's registered config
    class)."""
    return cast(OptimizerConfig, configs["optimizer"])
