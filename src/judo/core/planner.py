"""The `Planner` contract: what the closed loop calls of a controller (the app reads more:
`PlannerView`).

Two classes satisfy it: `judo.core.controller.Controller` (an optimizer plans on rollouts) and
`judo.core.policies.policy_controller.PolicyController` (a policy's action or chunk is the plan).
Code that drives a plant types against `Planner` only, so either serves through the same loop with
no probing of which one it holds. `PlanServer` is what both serve alike (the plan at a time, the
warm start before the first: `task_warm_start`); both check each reading with
`judo.core.reading.checked_reading` at the top of every update.
"""

import inspect
import math
import warnings
from collections.abc import Callable
from typing import Any, Protocol, TypeVar, cast, runtime_checkable

import numpy as np

from judo.core.errors import JudoError
from judo.core.spline import Spline
from judo.core.task import Task


class CancelFlag(Protocol):
    """Anything with `is_set()`: a threading.Event, the app's stop signal, a planning cycle."""

    def is_set(self) -> bool: ...


class LoopSettings(Protocol):
    """What the loop reads of a
    planner's `config` (a `judo.core.configuration.controller_config.ControllerConfig`): the control
    rate (Hz), the watchdog's plan age (s), and whether a plan starts from the reading predicted to
    when it takes effect (latency compensation, feedback gains: a planner whose plans have none
    keeps `feedback` off)."""

    control_freq: float
    max_plan_age: float
    latency_compensation: bool
    feedback: bool


@runtime_checkable
class Planner(Protocol):
    """Plans from a reading and serves the plan; nu below is `task.command_size`. What the app reads
    besides (rewards, traces, the optimizer, the backend, its kind) is
    `judo.core.planner_view.PlannerView`.

    Attributes:
        config: the loop's settings (a ControllerConfig: control_freq, max_plan_age,
            latency_compensation, ...); the app's planner runner replaces it between updates.
        task: the planning task, its own instance (the plant is the System's); its `config` may be
            replaced between updates.
    """

    @property
    def config(self) -> LoopSettings: ...

    @property
    def task(self) -> Task: ...

    def update_action(
        self,
        state: np.ndarray,
        time: float,
        system_metadata: dict[str, Any] | None = None,
        cancel: CancelFlag | None = None,
        deadline: float | None = None,
    ) -> Spline:
        """Plan from `state` (nq + nv,) at sim `time`, publish the new plan and return it; a failed
        update raises a JudoError and keeps the plan before in force. A set `cancel` ends it
        (PlanningCancelled); a `deadline` (a time.perf_counter() value) ends the optimizer
        iterations beyond `config.max_opt_iters` that would end after it. The plan carries what the
        update scored (`Spline.rewards`, `Spline.traces`) for the loop's records."""
        ...

    def action(self, time: float, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) control of the plan in force at sim `time`; the warm start from the (nq + nv,)
        `state` before the first plan."""
        ...

    def warm_start_action(self, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) what the plant gets before the first plan, from the (nq + nv,) plant `state`."""
        ...

    def reset(self) -> None:
        """Forget the plan; the next update starts from the warm start again."""
        ...

    def close(self) -> None:
        """Release threads, device memory and whatever else the planner holds."""
        ...


def task_warm_start(task: Task, state: np.ndarray | None, takes_state: bool) -> np.ndarray:
    """(nu,) `task.optimizer_warm_start(state)` as floats, unclamped; the planning model's start
    state (keyframe 0 or qpos0, at rest) stands in for a None `state`. `takes_state` False: the
    deprecated form without a state."""
    if not takes_state:
        return np.asarray(legacy_warm_start(task), dtype=float)
    if state is None:
        model = task.model
        qpos = model.key_qpos[0] if model.nkey else model.qpos0
        state = np.concatenate([qpos, np.zeros(model.nv)])
    return np.asarray(task.optimizer_warm_start(state), dtype=float)


ServerT = TypeVar("ServerT", bound="PlanServer")


class PlanServer:
    """What `Controller` and `PolicyController` serve alike: the current plan at a time, the task's
    warm start before the first plan, and closing on the way out of a `with` block.

    A subclass sets `task`, `_plan` (the Spline in force, or None), `_ctrl_low` and `_ctrl_high`
    ((nu,) bounds) and `_warm_start_takes_state`, and defines `close`.
    """

    task: Task
    _plan: Spline | None
    _ctrl_low: np.ndarray
    _ctrl_high: np.ndarray
    _warm_start_takes_state: bool

    def action(self, time: float, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) control of the current plan at sim `time` (held past its ends), within the
        ctrlrange, plus the gains' correction from the (nq + nv,) `state` in a plan with feedback.
        Before the first plan: the task's warm start from `state` (see `warm_start_action`)."""
        if not math.isfinite(time):
            raise JudoError(f"action time must be a finite number of seconds, got {time}")
        if self._plan is None:
            return self.warm_start_action(state)
        return self._plan(time, state)

    def warm_start_action(self, state: np.ndarray | None = None) -> np.ndarray:
        """(nu,) the task's warm start from the (nq + nv,) plant `state`, clamped to the ctrlrange:
        what a plant gets before the first plan. Without a state, the planning model's start state
        (keyframe 0 or qpos0) stands in."""
        warm = task_warm_start(self.task, state, self._warm_start_takes_state)
        return np.clip(warm, self._ctrl_low, self._ctrl_high)

    def close(self) -> None:
        """Release what the planner holds (threads, device memory)."""
        raise NotImplementedError

    def __enter__(self: ServerT) -> ServerT:
        """`with judo.make_controller(...) as controller:` closes it on the way out."""
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def warm_start_takes_state(task: Task) -> bool:
    """Whether `task.optimizer_warm_start` takes the plant state. The old no-argument form (it read
    the task's own `data`, which the controller never steps) still works, with a
    DeprecationWarning."""
    try:
        parameters = inspect.signature(task.optimizer_warm_start).parameters
    except (TypeError, ValueError):  # a builtin or an odd callable: assume the current form
        return True
    if parameters:
        return True
    warnings.warn(
        f"{type(task).__name__}.optimizer_warm_start() without arguments is deprecated: define "
        "optimizer_warm_start(self, state) and read the (nq + nv,) plant state it is given, "
        "not self.data",
        DeprecationWarning,
        stacklevel=3,
    )
    return False


def legacy_warm_start(task: Task) -> Any:
    """`task.optimizer_warm_start()` in the deprecated form without the state, for a task whose
    override takes none (`warm_start_takes_state` False); Task declares the current form, hence the
    cast."""
    return cast(Callable[[], Any], task.optimizer_warm_start)()
