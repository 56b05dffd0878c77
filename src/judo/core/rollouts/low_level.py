"""A low-level policy inside every rollout (the Spot hierarchy of the seed paper's 0.1.0 release,
batched).

A task declares one with `Task.low_level()`: the optimizer then plans the policy's commands (C
numbers per step within `command_range`, e.g. a target position or a base velocity) instead of the
actuators' ctrl, and every `every` (k) physics steps the policy turns each rollout's command, state,
previous action and sim time (a gait's clock) into the ctrl held for the next k steps (or, for a
chunk policy, the ctrl of each of those k steps read off the chunk's spline). Three places run it,
the first two on one `PolicyStepper` (core/rollouts/stepper.py):
  - `LowLevelRollout` (core/rollouts/low_level_rollout.py), the CPU rollout backend's wrapper: each
    of the pool's workers runs the whole tick loop of its own block of rows (`mujoco.rollout` k
    steps at a time, states carried between ticks), and at every tick one batched `Policy.act` on
    its block's (B, O) observations makes the next ctrl: one thread hand-off per update rather than
    one per tick, and one worker's `act` overlaps the other's physics. `act` and the hooks are
    therefore called from several threads at once (as they already were by the plant's thread and
    the planner's): they must not keep shared mutable state;
  - `LowLevelPlant` (`LowLevel.plant`), inside `MujocoSystem`: the simulated plant runs the policy
    on the command it is served, every k of its steps, as the robot's own controller would (a
    robot's `System` runs it itself), turning its actions into ctrl exactly as the rollouts do;
  - `with_low_level` (core/rollouts/low_level_rollout.py too), which the Controller calls on its
    backend: the wrapper, or a LowLevelBackendError for a backend that cannot run a policy between
    its steps (MuJoCo Warp, for now).
Each chunk starts MuJoCo's solver cold (`qacc_warmstart` zero, as every rollout of a planning cycle
starts); models without active constraints are unaffected.
"""

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import mujoco
import numpy as np

from judo.core.policy import Policy, PolicyError
from judo.core.rollouts.stepper import PolicyStepper
from judo.core.spline import MIN_KNOTS, SplineBasis, SplineOrder

ObservationFn = Callable[..., np.ndarray]
"""(commands (B, C), states (B, nq + nv), previous_actions (B, A), times (B,)[, out=(B, O)]) -> (B,
O) observations; a hook with an `out` keyword parameter is handed the buffer to write into and
return."""
ToCtrlFn = Callable[[np.ndarray], np.ndarray]
"""(B, A) actions -> (B, nu) ctrl."""


def takes_out(hook: Callable[..., Any]) -> bool:
    """Whether `hook` can be called with an `out` keyword argument (a parameter of that name, or
    **kwargs)."""
    try:
        parameters = inspect.signature(hook).parameters.values()
    except (TypeError, ValueError):  # a callable without a signature Python can read
        return False
    return any(
        (p.name == "out" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY))
        or p.kind == p.VAR_KEYWORD
        for p in parameters
    )


@dataclass
class LowLevel:
    """What a task returns from `Task.low_level()` to plan commands over a low-level policy.

    Attributes:
        policy: a Policy run every `every` physics steps, batched over rollouts: a per-step
            one (horizon 1), whose action is held for the k steps, or a chunk policy (horizon
            H > 1), whose H knots span
            `chunk_horizon` seconds as a `chunk_spline_order` spline that gives each of the k steps
            its own action
            (an action chunk, as `distill --kind chunk` writes; its metadata's "horizon"
            and "spline_order" are the defaults of the two fields).
        command_range: (C, 2) the limits of each planned command; C is the size the optimizer plans.
        every: physics steps per policy tick, k: the policy runs at 1 / (k * timestep) Hz.
        observation: (commands (B, C), states (B, nq + nv), previous_actions (B, A),
            times (B,)) -> (B, O), vectorized numpy; previous_actions are the policy's own outputs
            of the last tick (zeros at a rollout's or a plant's start), times each row's sim
            time (s; the plant's clock, carried on through the rollouts, for a policy that keeps a
            gait's rhythm). A hook that also takes an `out` keyword is handed the (B, O) buffer of
            the rollouts' tick to write into and return (no temporaries; it may be None, on
            the plant and in `check`: then the hook allocates). None: [commands, states], so O = C +
                nq + nv.
        to_ctrl: (B, A) actions -> (B, nu) ctrl, held for the next k steps (MuJoCo clamps it to the
            ctrlrange). None: the actions are the ctrl (A = nu).
        chunk_horizon: seconds a chunk's knots span (chunk policies only); None: the
            policy's "horizon" metadata.
        chunk_spline_order: "zero", "linear" or "cubic" (chunk policies only); None:
            its "spline_order" metadata.
    """

    policy: Policy
    command_range: np.ndarray
    every: int = 1
    observation: ObservationFn | None = None
    to_ctrl: ToCtrlFn | None = None
    chunk_horizon: float | None = None
    chunk_spline_order: str | None = None
    chunk: SplineBasis | None = field(init=False, default=None)
    """The chunk's knot layout (set from the two fields above), or None for a per-step policy."""
    _hook_with_out: ObservationFn | None = field(
        init=False, default=None, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        self.command_range = np.array(self.command_range, dtype=float)
        shape = self.command_range.shape
        if len(shape) != 2 or shape[1] != 2 or shape[0] < 1:
            raise PolicyError(f"command_range must have shape (C, 2) with C >= 1, got {shape}")
        if (self.command_range[:, 0] > self.command_range[:, 1]).any():
            raise PolicyError(
                f"command_range needs low <= high in every row, got {self.command_range.tolist()}"
            )
        if (
            isinstance(self.every, bool)
            or not isinstance(self.every, (int, np.integer))
            or self.every < 1
        ):
            raise PolicyError(
                f"every (physics steps per policy tick) must be an integer >= 1, got {self.every!r}"
            )
        self.chunk = None if self.policy.horizon == 1 else self._chunk_basis()
        self._hook_with_out = (
            self.observation
            if self.observation is not None and takes_out(self.observation)
            else None
        )

    def _chunk_basis(self) -> SplineBasis:
        """The knot layout of the policy's chunks; PolicyError (one line) where it is not known or
        does not fit."""
        metadata, horizon = getattr(self.policy, "metadata", {}), self.policy.horizon
        span = self.chunk_horizon if self.chunk_horizon is not None else metadata.get("horizon")
        order = self.chunk_spline_order or metadata.get("spline_order", "cubic")
        try:
            span = float(span) if span is not None else float("nan")
        except ValueError:
            span = float("nan")
        if not span > 0:
            raise PolicyError(
                f"policy {self.policy.name!r} gives chunks of {horizon} actions (not horizon "
                "1) but no chunk_horizon "
                "(seconds its knots span) > 0; give one, or write it as the policy's "
                "'horizon' metadata"
            )
        if order not in MIN_KNOTS or horizon < MIN_KNOTS[order]:
            raise PolicyError(
                f"policy {self.policy.name!r} gives chunks of {horizon} actions; "
                "chunk_spline_order must be one of "
                f"{[name for name, least in MIN_KNOTS.items() if least <= horizon]}, got {order!r}"
            )
        return SplineBasis(np.linspace(0.0, span, horizon), cast(SplineOrder, order))

    def step_weights(self, num_steps: int, timestep: float) -> np.ndarray:
        """(num_steps, H) the weights that give each of a tick's `num_steps` steps its action from
        the H actions of one `act`: the chunk's spline at 0, dt, 2 dt, ...; all ones for a per-step
        policy (held)."""
        if self.chunk is None:
            return np.ones((num_steps, 1))
        return self.chunk.weights(np.arange(num_steps) * timestep)

    @property
    def command_size(self) -> int:
        """C, the number of commands the optimizer plans per step."""
        return len(self.command_range)

    def observe(
        self,
        commands: np.ndarray,
        states: np.ndarray,
        previous_actions: np.ndarray,
        times: np.ndarray,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """(B, O) the policy's observations: the task's `observation`, or [commands, states] without
        one (written into the (B, O) `out` where given, by the default and by a hook that takes
        `out`)."""
        hook = self.observation
        if hook is not None:
            # (a hook set after construction is called without `out`)
            if hook is self._hook_with_out:
                return hook(commands, states, previous_actions, times, out=out)
            return hook(commands, states, previous_actions, times)
        if out is None:
            return np.concatenate([commands, states], axis=1)
        out[:, : commands.shape[1]] = commands
        out[:, commands.shape[1] :] = states
        return out

    def plant(self, model: mujoco.MjModel) -> "LowLevelPlant":
        """The simulated plant's side of this policy on the plant model `model` (what `MujocoSystem`
        runs)."""
        return LowLevelPlant(self, model)

    def stepper(self, model: mujoco.MjModel) -> PolicyStepper:
        """A `PolicyStepper` that runs this policy on `model`: every k steps, its actions held or
        off its chunk."""
        timestep = model.opt.timestep
        weights = None if self.chunk is None else (lambda n: self.step_weights(n, timestep))
        return PolicyStepper(
            model,
            self.policy.action_size,
            self.every,
            weights,
            self.to_ctrl,
            self.policy.observation_size,
        )

    def ctrl(self, actions: np.ndarray) -> np.ndarray:
        """(B, nu) ctrl of (B, A) `actions`: the task's `to_ctrl`, or the actions themselves."""
        return actions if self.to_ctrl is None else self.to_ctrl(actions)

    def check(self, model: mujoco.MjModel) -> None:
        """Raise a one-line PolicyError unless the policy takes the observation the hooks build on
        `model` and its actions make `model.nu` ctrl: both hooks are tried once on a batch of
        one."""
        state = np.concatenate([model.qpos0, np.zeros(model.nv)])[None]
        try:
            previous = np.zeros((1, self.policy.action_size))
            observation = self.observe(
                np.zeros((1, self.command_size)), state, previous, np.zeros(1)
            )
        except Exception as err:
            raise PolicyError(
                f"the low-level observation hook failed on a batch of one: {err!r}"
            ) from err
        if np.ndim(observation) != 2 or len(observation) != 1:
            raise PolicyError(
                "the low-level observation hook must return (B, O), got shape "
                f"{np.shape(observation)}"
            )
        self.policy.check_fits(None, np.shape(observation)[1], self.policy.action_size)
        try:
            ctrl = self.ctrl(np.zeros((1, self.policy.action_size)))
        except Exception as err:
            raise PolicyError(
                f"to_ctrl failed on the (1, {self.policy.action_size}) actions of policy "
                f"{self.policy.name!r}: {err!r}"
            ) from err
        if np.shape(ctrl) != (1, model.nu):
            what = (
                "to_ctrl returns"
                if self.to_ctrl is not None
                else (f"policy {self.policy.name!r} gives actions of")
            )
            raise PolicyError(
                f"{what} shape {np.shape(ctrl)[1:]} per row, but the model has nu = {model.nu} "
                "actuators"
            )


class LowLevelPlant:
    """The plant's side of a low-level policy: `MujocoSystem` serves it the command, and every k of
    its steps it runs the policy on that command, the plant's state and its previous action, as the
    robot's own controller would, writing the ctrl the plant then holds.

    Attributes:
        low_level: the plant task's declaration.
        command: (C,) the command in force, as last served (zeros until then).
    """

    def __init__(self, low_level: LowLevel, model: mujoco.MjModel) -> None:
        low_level.check(model)
        self.low_level = low_level
        self.command = np.zeros(low_level.command_size)
        self._stepper = low_level.stepper(model)
        self._stepper.start(1, low_level.every, np.zeros(self._stepper.nstate))
        self._tick_ctrl = self._stepper.inputs[low_level.every][0]  # (k, nu): this tick's ctrl
        self._steps = 0

    def reset(self) -> None:
        """Forget the previous action and restart the tick count (after a reset of the plant)."""
        self._stepper.previous[:] = 0.0
        self._steps = 0

    def before_step(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """On every k-th step, run the policy to make the ctrl of this tick's k steps; on every step
        write that step's into `data.ctrl`. PolicyError for a non-finite action."""
        tick_step = self._steps % self.low_level.every
        if tick_step == 0:
            stepper, policy = self._stepper, self.low_level.policy
            state = np.concatenate([data.qpos, data.qvel])[None]
            times = np.array([data.time])
            observation = self.low_level.observe(self.command[None], state, stepper.previous, times)
            # (1, H, A)
            chunk = policy.checked_act(np.asarray(observation, dtype=float), require_finite=False)
            if not np.isfinite(chunk).all():
                raise PolicyError(
                    f"low-level policy {policy.name!r} returned non-finite actions on the plant"
                )
            # the tick's ctrl, held or off the chunk
            stepper.act(slice(0, 1), chunk, self.low_level.every)
        data.ctrl[:] = self._tick_ctrl[tick_step]
        self._steps += 1
