"""`LowLevelRollout`: the CPU rollout backend's wrapper that runs a task's low-level policy
(core/rollouts/low_level.py) inside every rollout, and `with_low_level`, which the Controller calls
to put it around its backend (or to refuse a backend that cannot run a policy between its steps).
"""

from typing import cast

import numpy as np

from judo.core.errors import JudoError
from judo.core.planner import CancelFlag
from judo.core.rollouts.backend import RolloutBackend
from judo.core.rollouts.low_level import LowLevel
from judo.core.rollouts.rollout import RolloutPool
from judo.core.task import LowLevelCommands


class LowLevelBackendError(JudoError):
    """A rollout backend that cannot run a task's low-level policy between its physics steps."""


def check_low_level_backend(name: str, low_level: LowLevelCommands | None) -> None:
    """Raise LowLevelBackendError, before any backend is built, when a task with a low-level policy
    asks for a rollout backend other than "cpu" (MuJoCo Warp cannot run a policy between its steps
    yet)."""
    if low_level is not None and name != "cpu":
        raise LowLevelBackendError(
            f"the {name} rollout backend cannot run a low-level policy inside its rollouts "
            "yet; expected the cpu "
            "backend for a task whose low_level() returns a policy"
        )


def with_low_level(backend: RolloutBackend, low_level: LowLevelCommands | None) -> RolloutBackend:
    """`backend` itself without a low-level policy, else a `LowLevelRollout` around it. A backend
    that cannot run the policy between its steps is closed and LowLevelBackendError raised."""
    if low_level is None:
        return backend
    if not isinstance(backend, RolloutPool):
        backend.close()
        raise LowLevelBackendError(
            f"the {type(backend).__name__} rollout backend cannot run a low-level policy "
            "inside its rollouts yet; "
            "expected the cpu backend (RolloutPool) for a task whose low_level() returns a policy"
        )
    return LowLevelRollout(backend, cast(LowLevel, low_level))  # what a task's low_level() returns


class LowLevelRollout(RolloutBackend):
    """Rolls out planned commands through a low-level policy on a `RolloutPool`'s threads.

    `rollout(initial_state, commands, mocap)` takes (N, T, C) commands where a plain backend takes
    ctrl. Each worker of the pool takes its block of B rows (`RolloutPool.blocks`) through every
    tick j (steps jk to jk + k - 1, the last tick possibly shorter): it builds the block's (B, O)
    observations from the commands at step jk, the states reached so far and the previous actions,
    makes one batched `act` for the block, and rolls each of its rollouts k steps on from its own
    state with the ctrl held. A rollout whose policy returned non-finite actions gets NaN states and
    sensors, so it never wins. Buffers are allocated per (N, T) and reused, so the returned arrays
    are overwritten by the next call.

    Attributes:
        inner: the pool the physics runs on; closed with this backend.
        low_level: the task's declaration.
        act_calls: batched `act` calls made so far (one per tick and worker block of every rollout
            call).
    """

    def __init__(self, inner: RolloutPool, low_level: LowLevel) -> None:
        low_level.check(inner.model)
        self.inner, self.low_level = inner, low_level
        self.model, self.num_workers = inner.model, inner.num_workers
        self.act_calls = 0
        self._stepper = low_level.stepper(inner.model)
        self._shape: tuple[int, int] | None = None

    def set_models(self, models) -> None:
        """See `RolloutBackend.set_models`: the inner pool rolls each block of rows out on its
        model."""
        self.inner.set_models(models)

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """See `RolloutBackend.rollout`, with `controls` the (N, T, C) planned commands; returns the
        (N, T, nstate) states and (N, T, nsensordata) sensors after each step."""
        commands = controls
        num_rollouts, num_steps, size = commands.shape
        if size != self.low_level.command_size:
            raise JudoError(
                f"the low-level rollout takes (N, T, {self.low_level.command_size}) "
                f"commands, got {commands.shape}"
            )
        if self._shape != (num_rollouts, num_steps):
            self._shape = (num_rollouts, num_steps)
            self._states = np.zeros((num_rollouts, num_steps, self._stepper.nstate))
            self._sensors = np.zeros((num_rollouts, num_steps, self.model.nsensordata))
        stepper, low = self._stepper, self.low_level
        stepper.start(num_rollouts, num_steps, initial_state, mocap)
        num_state = 1 + self.model.nq + self.model.nv  # STATE_SPEC starts [time, qpos, qvel]

        # per block: its (B, O) buffer, (B, T, C) commands, and the states and times in `current`
        views = {
            rows.start: (
                stepper.observations[rows],
                commands[rows],
                stepper.current[rows, 1:num_state],
                stepper.current[rows, 0],
            )
            for rows in self.inner.blocks(num_rollouts)
        }

        def observe(
            rows: slice, start: int, current: np.ndarray, previous: np.ndarray
        ) -> np.ndarray:
            out, block_commands, states, times = views[rows.start]
            return low.observe(block_commands[:, start], states, previous, times, out)

        def act(rows: slice, observations: np.ndarray) -> np.ndarray:
            # (B, H, A); NaN: that rollout loses
            return low.policy.checked_act(observations, require_finite=False)

        def record(rows: slice, start: int, stop: int) -> None:
            self._states[rows, start:stop] = stepper.states[stop - start][rows]
            self._sensors[rows, start:stop] = stepper.sensors[stop - start][rows]

        blocks = stepper.run_blocks(self.inner, observe, act, record)
        self.act_calls += len(stepper.ticks) * blocks
        if not stepper.finite.all():
            self._states[~stepper.finite] = np.nan
            self._sensors[~stepper.finite] = np.nan
        return self._states, self._sensors

    @property
    def cancel(self) -> CancelFlag | None:
        """See `RolloutBackend.cancel`: the inner pool's, which it polls between its pieces, every
        tick."""
        return self.inner.cancel

    @cancel.setter
    def cancel(self, cancel: CancelFlag | None) -> None:
        self.inner.cancel = cancel

    def close(self) -> None:
        """Close the inner pool."""
        self.inner.close()
