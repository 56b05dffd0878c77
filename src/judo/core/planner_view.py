"""`PlannerView`: what the app and the GUI read of a planner beyond what the closed loop calls
(`Planner`).

The loop drives a `judo.core.planner.Planner`; the app's sessions, commands and GUI also show and
edit what it plans with. They ask the planner instead of probing which kind it is: its `kind` (a
`PlannerKind`), the config kinds it has (`config_kinds`, `configs`), whether it takes edited configs
(`check_configs`), what one planning cycle rolls out (`cycle_size`), and which controller fields it
uses (`controller_fields`). `Controller` and `PolicyController` implement both protocols
(`AppPlanner`).
"""

import enum
import functools
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from judo.core.configuration.config import Config
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.optimizer import Optimizer
from judo.core.planner import Planner
from judo.core.policy import Policy
from judo.core.rollouts.backend import RolloutBackend


class PlannerKind(enum.Enum):
    """What plans: an optimizer on rollouts (MPC), or a policy's action or chunk (POLICY).

    The value is the name the app lists the kind under beside the registered optimizers: the GUI's
    optimizer dropdown and `App.switch_optimizer` take "policy" for the app's policy.
    """

    MPC = "mpc"
    POLICY = "policy"

    @classmethod
    def of_choice(cls, optimizer: str) -> "PlannerKind":
        """The kind an optimizer choice names: POLICY for "policy", MPC for a registered optimizer's
        name."""
        return cls.POLICY if optimizer == cls.POLICY.value else cls.MPC


@dataclass(frozen=True)
class CycleSize:
    """How many rollout steps one planning cycle takes: rollouts x models x iterations x steps."""

    rollouts: int
    models: int
    iterations: int
    steps: int

    @functools.cached_property
    def total(self) -> int:
        """Rollout steps of the whole cycle (at most: an optimizer may stop its iterations early);
        worked out once."""
        return self.rollouts * self.models * self.iterations * self.steps

    def __str__(self) -> str:
        return (
            f"{self.rollouts} x {self.models} x {self.iterations} x {self.steps} = "
            f"{self.total:,} steps"
        )


@runtime_checkable
class PlannerView(Protocol):
    """What the app reads of a planner; nu below is `task.command_size`.

    Attributes:
        kind: what plans (PlannerKind.MPC: an optimizer; PlannerKind.POLICY: a policy).
        config_kinds: the kinds of config it plans with, in the app's order: ("controller",
            "optimizer", "task") for an optimizer, ("controller", "task") for a policy.
        controller_fields: the ControllerConfig fields it uses (the GUI shows a widget for these
            only).
        nominal_knots: (num_knots, nu) the knots of the latest plan, or None before the first
            update.
        rewards: (num_rollouts,) the rewards of the latest update's rollouts; (0,) where nothing is
            scored.
        traces: (1 + num_shown, T, num_trace_sensors, 3) positions of the trace sensors along the
            latest plan's rollouts; (0, 0, 0, 3) where nothing is rolled out.
        optimizer: the optimizer whose config the app edits, or None where a policy plans.
        backend: the rollout backend, or None where nothing is rolled out.
        backend_name: the name the backend was built from ("cpu", "warp"), or None where nothing is
            rolled out.
        proposal_policy: the policy whose candidates join the optimizer's samples, or None.
        iterations_run: optimizer iterations the latest update ran (0 where a policy plans).
    """

    @property
    def kind(self) -> PlannerKind: ...

    @property
    def config_kinds(self) -> tuple[str, ...]: ...

    @property
    def controller_fields(self) -> tuple[str, ...]: ...

    @property
    def nominal_knots(self) -> np.ndarray | None: ...

    @property
    def rewards(self) -> np.ndarray: ...

    @property
    def traces(self) -> np.ndarray: ...

    @property
    def optimizer(self) -> Optimizer | None: ...

    @property
    def backend(self) -> RolloutBackend | None: ...

    @property
    def backend_name(self) -> str | None: ...

    @property
    def proposal_policy(self) -> Policy | None: ...

    @property
    def iterations_run(self) -> int: ...

    def configs(self) -> dict[Any, Config]:
        """{kind: config} of its `config_kinds`, the configs it plans with now."""
        ...

    def check_configs(self, configs: dict[Any, Config]) -> None:
        """ConfigError (or PolicyError) unless it can plan with `configs` ({kind: config} of its
        `config_kinds`), so that an edit is refused when it is made, not at the next update."""
        ...

    def cycle_size(self, configs: dict[Any, Config]) -> CycleSize | None:
        """The size of one planning cycle under `configs` ({kind: config} of its `config_kinds`), or
        None where a cycle rolls nothing out (a policy)."""
        ...


@runtime_checkable
class AppPlanner(Planner, PlannerView, Protocol):
    """A planner the app runs: the closed loop drives it (`Planner`), the app and the GUI read
    it (`PlannerView`)."""

    config: ControllerConfig
    """The whole ControllerConfig (the loop reads only its `LoopSettings`); the planner runner
    replaces it."""
