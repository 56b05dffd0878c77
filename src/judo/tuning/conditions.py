"""The conditions a tune scores each trial under, and how their metrics become the trial's value.

A condition is one episode setting: a fixed planning latency (`latency_ms`) and a replanning rate
(`control_freq`, the controller's). `--conditions latency_ms=0,25 control_freq=20,50` crosses the
lists (4 conditions); with `--conditions-mode listed` the i-th values of every name form the i-th
condition (all lists the same length). A trial's value is the objective metric of each condition
(its mean over seeds) aggregated by `mean`, `worst`, or `cvar` (the mean of the worst alpha
fraction, at least one). Without --conditions a study uses the task's check set: control_freq 20 and
the task's own rate, crossed with latency 0 and `Task.check_latency_ms`.
"""

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import lookup_task, make_config
from judo.core.errors import JudoError

Aggregate = Literal["mean", "worst", "cvar"]
AGGREGATES: tuple[str, ...] = ("mean", "worst", "cvar")
ConditionsMode = Literal["crossed", "listed"]
CONDITION_NAMES = ("control_freq", "latency_ms")
"""The settings a condition can set, in the order labels name them."""
MAX_LATENCY_MS = 60_000.0
"""The largest latency a condition accepts, as evaluate's --latency-ms."""


class ConditionError(JudoError):
    """A --conditions entry that names no condition, has no values, or a value out of range."""


@dataclass(frozen=True)
class Condition:
    """One episode setting of a trial.

    Attributes:
        control_freq: replanning rate (Hz) set on the controller config; None keeps the config's.
        latency_ms: fixed planning latency in ms of sim time; None keeps the study's --latency.
    """

    control_freq: float | None = None
    latency_ms: float | None = None

    @property
    def label(self) -> str:
        """E.g. "control_freq=20 latency_ms=25" (only the names it sets; "default" when none)."""
        parts = [
            f"{name}={value:g}"
            for name in CONDITION_NAMES
            if (value := getattr(self, name)) is not None
        ]
        return " ".join(parts) or "default"


def parse_values(entry: str) -> tuple[str, list[float]]:
    """`NAME=V1,V2,...` -> (name, values); ConditionError for an unknown name or a bad number."""
    name, has_values, text = entry.partition("=")
    name = name.strip()
    if name not in CONDITION_NAMES:
        raise ConditionError(
            f"--conditions {entry!r}: unknown condition {name!r}; valid conditions are: "
            f"{', '.join(CONDITION_NAMES)}"
        )
    example = "latency_ms=0,25,50" if name == "latency_ms" else "control_freq=20,50"
    try:
        if not has_values or not text.strip():
            raise ValueError
        values = [float(value) for value in text.split(",")]
    except ValueError:
        raise ConditionError(
            f"--conditions {entry!r}: expected {name}=VALUE[,VALUE...] with numbers, e.g. {example}"
        ) from None
    for value in values:
        if name == "control_freq" and not (math.isfinite(value) and value > 0):
            raise ConditionError(
                f"--conditions {entry!r}: control_freq must be a positive rate in Hz, got {value:g}"
            )
        if name == "latency_ms" and not (0 <= value <= MAX_LATENCY_MS):
            raise ConditionError(
                f"--conditions {entry!r}: latency_ms must be from 0 to {MAX_LATENCY_MS:g} "
                f"ms, got {value:g}"
            )
    return name, list(dict.fromkeys(values))


def parse_conditions(entries: Sequence[str], mode: ConditionsMode = "crossed") -> list[Condition]:
    """The conditions of `--conditions` entries, crossed or listed (see the module docstring).

    Raises ConditionError for an unknown name (listing the valid ones), a name given twice, a bad
    value, or listed lists of different lengths.
    """
    if mode not in ("crossed", "listed"):
        raise ConditionError(
            f"unknown --conditions-mode {mode!r}; valid modes are: crossed, listed"
        )
    lists: dict[str, list[float]] = {}
    for entry in entries:
        name, values = parse_values(entry)
        if name in lists:
            raise ConditionError(
                f"--conditions names {name} twice; give all its values once, e.g. {name}=20,50"
            )
        lists[name] = values
    if not lists:
        return []
    names = list(lists)
    if mode == "crossed":
        rows = list(itertools.product(*lists.values()))
    else:
        lengths = {name: len(values) for name, values in lists.items()}
        if len(set(lengths.values())) > 1:
            given = ", ".join(f"{name} has {length}" for name, length in lengths.items())
            raise ConditionError(
                "--conditions-mode listed pairs the i-th values of each name, so every list "
                "needs the same length; "
                f"{given}"
            )
        rows = list(zip(*lists.values(), strict=True))
    return [Condition(**dict(zip(names, row, strict=True))) for row in rows]


def check_conditions(task_name: str) -> list[Condition]:
    """The task's check set: its slowest rate (`Task.min_control_freq`, 20 Hz unless the task needs
    more) and its own rate, crossed with latency 0 and its check latency
    (`Task.check_latency_ms`)."""
    task_cls = lookup_task(task_name)[0]
    own_rate = make_config(ControllerConfig, task_name).control_freq
    rates = list(dict.fromkeys([float(task_cls.min_control_freq), float(own_rate)]))
    latencies = [0.0, float(task_cls.check_latency_ms)]
    return [Condition(rate, latency) for rate, latency in itertools.product(rates, latencies)]


def aggregate(values: Sequence[float], how: Aggregate, maximize: bool, alpha: float = 0.5) -> float:
    """One value from the conditions' `values`: their mean, the worst, or the mean of the worst
    `alpha` fraction.

    "Worst" is the lowest when `maximize`, else the highest. cvar averages the ceil(alpha * n) worst
    (at least one), so alpha 1 is the mean and a small alpha the worst. NaN when `values` is empty
    or holds a NaN.
    """
    if how not in AGGREGATES:
        raise ConditionError(
            f"unknown --aggregate {how!r}; valid aggregates are: {', '.join(AGGREGATES)}"
        )
    if not 0 < alpha <= 1:
        raise ConditionError(f"--cvar-alpha must be in (0, 1], got {alpha:g}")
    if not values or any(math.isnan(value) for value in values):
        return math.nan
    ordered = sorted(values, reverse=not maximize)  # worst first
    if how == "mean":
        return math.fsum(ordered) / len(ordered)
    if how == "worst":
        return ordered[0]
    count = max(1, math.ceil(alpha * len(ordered) - 1e-9))
    return math.fsum(ordered[:count]) / count
