"""A policy as the controller: each control update is one `act`, and its action or chunk is the
plan.

`PolicyController` is a `Planner` (judo.core.planner), as `Controller` is, so the one closed loop
(`judo.loop.closed_loop.ClosedLoop`), evaluate and the app drive either: `update_action` returns a
plan `Spline`, `action(t)` serves it, `config` holds the control rate and the watchdog's
`max_plan_age`, and `reset`, `close` and `warm_start_action` behave alike. So the watchdog, the
estimator, the latency model and the recorders serve and watch a policy's plan as they do an
optimizer's, with no second loop:
  - a per-step policy (horizon H = 1): the plan holds its action until the next update;
  - a chunk policy (H > 1): the chunk is the plan's H knots, placed at `linspace(0, config.horizon,
    H)` and joined by `config.spline_order` (the MPC plan's own layout, so a policy distilled from a
    dataset's `plan/knots` gives back the same plans), served until the next inference.
A policy that returns NaN fails its update like an optimizer's NaN knots (NonFiniteKnotsError,
counted by the loop): the plan before stays in force and the watchdog serves the task's
`safe_action` once it is too old.

With an `expert` Controller, every update also runs the MPC from the same state (after the policy,
so it never delays the policy's plan within the update): the policy drives the plant while the MPC
labels the states it visits (`python -m judo collect --policy FILE.onnx --optimizer O`). The
expert's `rewards` and `traces` are reported.
"""

import dataclasses
from pathlib import Path
from time import perf_counter_ns
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.config import check_seed, with_updates
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.controller import Controller
from judo.core.errors import ConfigError, NonFiniteKnotsError, NonFiniteRewardError
from judo.core.planner import CancelFlag, PlanServer, warm_start_takes_state
from judo.core.planner_view import PlannerKind
from judo.core.policy import NonFiniteActionsError, Policy, PolicyError
from judo.core.reading import checked_reading, model_at
from judo.core.spline import MIN_KNOTS, Spline, SplineBasis
from judo.core.task import Task, new_task

POLICY_CONFIG_FIELDS = ("control_freq", "horizon", "spline_order")
"""ControllerConfig fields a policy's metadata may set (as strings): the rate it was trained to act
at, and for a chunk policy the span and interpolation of its chunk. Fields given on a command line
or in code win."""


POLICY_USES_FIELDS = (*POLICY_CONFIG_FIELDS, "max_plan_age", "latency_compensation")
"""ControllerConfig fields a PolicyController uses; the others (iterations, randomization, risk,
traces, proposals) only an optimizer's Controller does, so the GUI hides them while a policy
drives."""


def as_policy(policy: "Policy | str | Path") -> Policy:
    """`policy` itself, or the ONNX file it names loaded as an `OnnxPolicy` (on onnxruntime)."""
    if isinstance(policy, Policy):
        return policy
    if isinstance(policy, (str, Path)):
        from judo.core.policies.onnx_policy import OnnxPolicy

        return OnnxPolicy(policy)
    raise PolicyError(
        f"a policy must be a judo.Policy or the path of an .onnx file, got {type(policy).__name__}"
    )


def policy_config_fields(policy: Policy) -> dict[str, Any]:
    """The POLICY_CONFIG_FIELDS its metadata gives, as ControllerConfig values ({"control_freq":
    50.0, ...})."""
    metadata = getattr(policy, "metadata", {})
    fields: dict[str, Any] = {}
    for name in POLICY_CONFIG_FIELDS:
        if name in metadata:
            value = metadata[name]
            try:
                fields[name] = value if name == "spline_order" else float(value)
            except (TypeError, ValueError):
                raise PolicyError(
                    f"policy {policy.name!r}: metadata {name}={value!r} is not a number"
                ) from None
    return fields


def policy_config(policy: Policy, base: ControllerConfig | None = None) -> ControllerConfig:
    """`base` (ControllerConfig() when None) with the fields the policy's metadata sets; PolicyError
    if they do not fit."""
    try:
        return with_updates(base or ControllerConfig(), policy_config_fields(policy))
    except ConfigError as err:
        raise PolicyError(
            f"policy {policy.name!r}: its metadata does not make a controller config: {err}"
        ) from None


class PolicyController(PlanServer):
    """Serves a policy's actions or chunks as the plan of the one closed loop.

    Args:
        task: the planning task; its `policy_observation` says what the policy sees.
        policy: a Policy whose sizes fit the task (checked now: PolicyError, one line, naming both).
        config: the loop's settings (control_freq, max_plan_age, latency_compensation; horizon and
            spline_order for a chunk); None: the expert's (a copy), or the defaults, with the fields
            the policy's metadata sets.
        task_name: the task's registered name, checked against the policy's metadata "task" (None:
            not checked).
        expert: a Controller on the same task that plans from every state the policy is served from,
            for labels.

    Attributes:
        config, task, policy, expert: the parts (`config.feedback` always off: a policy's plan has
            no gains).
        nominal_knots: (H, nu) the latest chunk (clamped to the ctrlrange), or None before the first
            update.
        inference_ms: wall time of each update's observation and `act`, in milliseconds (the
            expert's not counted).
        expert_failures: expert updates that failed on non-finite rewards or knots (its plan before
            stayed).
        kind, config_kinds, controller_fields: as a `PlannerView` (judo.core.planner_view):
            PlannerKind.POLICY,
            ("controller", "task") (no optimizer config), and POLICY_USES_FIELDS.
        optimizer, backend, backend_name, proposal_policy: None, as a `PlannerView` where a policy
            plans: nothing of its own is optimized, rolled out or proposed (an expert's are the
            expert's).
        iterations_run: 0, as a `PlannerView`: a policy runs no optimizer iterations of its own.
    """

    kind = PlannerKind.POLICY
    config_kinds = ("controller", "task")
    controller_fields = POLICY_USES_FIELDS
    optimizer: None = None
    backend: None = None
    backend_name: None = None
    proposal_policy: None = None
    iterations_run: int = 0

    def __init__(
        self,
        task: Task,
        policy: Policy,
        config: ControllerConfig | None = None,
        *,
        task_name: str | None = None,
        expert: Controller | None = None,
    ) -> None:
        observation_size = task.policy_observation_size()
        policy.check_fits(task_name, observation_size, task.nu)
        self.task, self.policy, self.expert = task, policy, expert
        self.config = (
            config
            if config is not None
            else policy_config(policy, None if expert is None else expert.config)
        )
        self.nominal_knots: np.ndarray | None = None
        self.inference_ms: list[float] = []
        self.expert_failures = 0
        self._num_state = task.model.nq + task.model.nv
        self._ctrl_low, self._ctrl_high = task.actuator_ctrlrange.T.copy()
        self._plan: Spline | None = None
        self._layout_key: tuple | None = None
        self._basis = self._chunk_basis()
        self._wants_sensors = type(task).policy_observation is not Task.policy_observation
        self._scratch = mujoco.MjData(task.model) if self._wants_sensors else None
        self._warm_start_takes_state = warm_start_takes_state(task)

    def __setattr__(self, name: str, value: Any) -> None:
        """`config` is kept with `feedback` off (a config set with it on is taken as a copy with it
        off): a policy's plan carries no gains, so the loop never predicts a start for them."""
        if name == "config" and value.feedback:
            value = dataclasses.replace(value, feedback=False)
        super().__setattr__(name, value)

    @property
    def name(self) -> str:
        """How titles name the controller: "policy NAME"."""
        return f"policy {self.policy.name}"

    @property
    def rewards(self) -> np.ndarray:
        """(num_rollouts,) the expert's last rewards; (0,) without an expert (a policy scores
        nothing)."""
        return self.expert.rewards if self.expert is not None else np.zeros(0)

    @property
    def traces(self) -> np.ndarray:
        """The expert's traces (see `Controller.traces`); (0, 0, 0, 3) without an expert."""
        return self.expert.traces if self.expert is not None else np.zeros((0, 0, 0, 3))

    def configs(self) -> dict[str, Any]:
        """{"controller": ..., "task": ...}: a policy has no optimizer config."""
        return {"controller": self.config, "task": self.task.config}

    def check_configs(self, configs: dict[Any, Any]) -> None:
        """Nothing to check before the next update: a policy rolls nothing out of its own."""

    def cycle_size(self, configs: dict[Any, Any]) -> None:
        """None: a policy's update rolls nothing out of its own (an expert's cycle is not the app's
        to size)."""
        return None

    def _chunk_basis(self) -> SplineBasis:
        """The knot layout of a chunk under the config in force, rebuilt when horizon or
        spline_order change."""
        cfg, horizon = self.config, self.policy.horizon
        key = (cfg.horizon, cfg.spline_order)
        if key == self._layout_key:
            return self._basis
        if horizon == 1:
            basis = SplineBasis(np.zeros(1), "zero")  # one knot: the action, held
        else:
            if horizon < MIN_KNOTS[cfg.spline_order]:
                raise PolicyError(
                    f"policy {self.policy.name!r} gives chunks of {horizon} actions, but a "
                    f"{cfg.spline_order} plan "
                    f"needs at least {MIN_KNOTS[cfg.spline_order]}; set spline_order to one of "
                    f"{[order for order, least in MIN_KNOTS.items() if least <= horizon]}"
                )
            basis = SplineBasis(np.linspace(0.0, cfg.horizon, horizon), cfg.spline_order)
        self._basis, self._layout_key = basis, key
        return basis

    def observe(
        self, state: np.ndarray, time: float, system_metadata: dict[str, Any] | None = None
    ) -> np.ndarray:
        """(1, O) the task's `policy_observation` of the (nq + nv,) `state`, with the planning
        model's sensors at it when the task overrides the hook, and the action in force as the
        previous action."""
        sensors = None
        if self._scratch is not None:
            sensors = (
                model_at(self.task.model, self._scratch, state, time, system_metadata)
                .sensordata[None]
                .copy()
            )
        previous = self.action(time, state)[None]
        observation = np.asarray(
            self.task.policy_observation(state[None], sensors, system_metadata, previous), float
        )
        if observation.shape != (1, self.policy.observation_size):
            raise PolicyError(
                f"{type(self.task).__name__}.policy_observation returned shape "
                f"{observation.shape}, expected "
                f"(1, {self.policy.observation_size}) for policy {self.policy.name!r}"
            )
        return observation

    def update_action(
        self,
        state: np.ndarray,
        time: float,
        system_metadata: dict[str, Any] | None = None,
        cancel: CancelFlag | None = None,
        deadline: float | None = None,
    ) -> Spline:
        """One inference from `state` (nq + nv,) at sim `time`: the policy's action (held) or chunk
        becomes the plan, which is published and returned. With an expert, the MPC then plans from
        the same state.

        Raises JudoError for a non-finite state or time, PolicyError for an observation or output of
        the wrong shape, and NonFiniteKnotsError when the policy returned NaN or infinite actions
        (the plan before stays in force; the closed loop counts it as a failed update). What the
        policy's `act` raises propagates.
        """
        state = checked_reading(state, time, self._num_state, "act on")
        basis = self._chunk_basis()
        started = perf_counter_ns()
        observation = self.observe(state, time, system_metadata)
        try:
            chunk = self.policy.checked_act(observation)[0]  # (H, nu)
        except NonFiniteActionsError as err:
            raise NonFiniteKnotsError(f"{err}; keeping the previous plan") from None
        finally:
            self.inference_ms.append((perf_counter_ns() - started) / 1e6)
        knots = self.nominal_knots = np.clip(chunk, self._ctrl_low, self._ctrl_high)
        self._plan = Spline(time, basis, knots, self._ctrl_low, self._ctrl_high)
        if self.expert is not None:
            try:
                self.expert.update_action(state, time, system_metadata, cancel, deadline)
            except (NonFiniteRewardError, NonFiniteKnotsError):
                self.expert_failures += 1  # the policy's plan is served all the same
        # the expert's, for the loop's records
        self._plan.rewards, self._plan.traces = self.rewards, self.traces
        return self._plan

    def reset(self) -> None:
        """Forget the plan (and the expert's); the next update starts from the warm start again."""
        self._plan, self.nominal_knots = None, None
        if self.expert is not None:
            self.expert.reset()

    def close(self) -> None:
        """Close the expert's rollout threads and the policy (where it has a `close`)."""
        if self.expert is not None:
            self.expert.close()
        close = getattr(self.policy, "close", None)
        if callable(close):
            close()


def make_policy_controller(
    task_name: str,
    policy: "Policy | str | Path",
    *,
    controller_config: ControllerConfig | None = None,
    expert: "Controller | str | None" = None,
    num_workers: int | None = None,
    seed: int | None = None,
    backend: str = "cpu",
) -> PolicyController:
    """A PolicyController for the registered task, serving `policy` (a Policy, or the path of an
    .onnx file).

    The policy is checked against the task now (its metadata's task, the observation and action
    sizes): a PolicyError of one line naming both. `controller_config` is used as it is; None gives
    the task's registered ControllerConfig (a copy of the expert's, with one) with the fields the
    policy's metadata sets. `expert` is a Controller of the task, or an optimizer's name (then made
    by `make_controller` with `num_workers`, `seed` and `backend`), that plans from the same states
    for labels; the policy controller shares its task instance and closes it. Without one, `seed`
    seeds the task's generator as `make_controller` does.
    """
    from judo.core.configuration.registry import (
        lookup_task,
        make_config,
        make_controller,
        with_model_overrides,
    )

    loaded = as_policy(policy)
    if isinstance(expert, str):
        expert = make_controller(
            task_name, expert, num_workers=num_workers, seed=seed, backend=backend
        )
    try:
        if expert is not None:
            task = expert.task
        else:
            check_seed(seed)
            task_cls, task_config_cls = lookup_task(task_name)
            task = with_model_overrides(new_task(task_cls), task_name)
            task.config = make_config(task_config_cls, task_name)
            if seed is not None:
                task.rng = np.random.default_rng(seed + 1)
        if controller_config is None:
            base = expert.config if expert is not None else make_config(ControllerConfig, task_name)
            controller_config = policy_config(loaded, base)
        return PolicyController(task, loaded, controller_config, task_name=task_name, expert=expert)
    except BaseException:
        if expert is not None:
            expert.close()
        raise
