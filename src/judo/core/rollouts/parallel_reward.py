"""Scoring a large batch of rollouts on several host threads.

`Task.reward` scores each row alone (its contract), so a batch can be cut into contiguous blocks of
rows, each scored on its own thread; numpy releases the GIL inside its array operations, so the
blocks run side by side and the result is the same row for row. This matters where the rollouts
leave the host's cores idle: on an H100, leap_cube's reward on one thread took 80 ms of a 167 ms
warp update at N = 4096 (README, GPU).

The warp backend asks for it (`RolloutBackend.reward_threads`); the CPU pool does not, since its
physics dwarfs the reward at the N it runs, and a default update there stays exactly as it was.
"""

from collections.abc import Callable
from typing import Any

import numpy as np

from judo.core.errors import JudoError
from judo.core.rollouts.rollout import DaemonThreadPool

MIN_BLOCK_ROWS = 256
"""Fewest rows a block gets: below this a thread's start-up and numpy's per-call overhead outweigh
the split."""


class ParallelReward:
    """Calls a reward on blocks of at least MIN_BLOCK_ROWS rows, up to `num_threads` blocks at once.

    With one thread, or fewer than 2 * MIN_BLOCK_ROWS rows, it is one plain call. The threads start
    at the first split call.
    """

    def __init__(self, num_threads: int) -> None:
        self.num_threads = max(1, num_threads)
        self._pool: DaemonThreadPool | None = None

    def __call__(
        self,
        reward: Callable[..., Any],
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        *args: Any,
    ) -> Any:
        """`reward(states, sensors, controls, *args)` over the (R, T, ...) arrays' rows; returns
        what one call would: the (R,) rewards (a block's wrong shape or type raises JudoError naming
        the block)."""
        num_rows = states.shape[0]
        blocks = min(self.num_threads, num_rows // MIN_BLOCK_ROWS)
        if blocks <= 1:
            return reward(states, sensors, controls, *args)
        if self._pool is None:
            self._pool = DaemonThreadPool(self.num_threads, "judo-reward")
        bounds = np.linspace(0, num_rows, blocks + 1).astype(int)
        spans = list(zip(bounds[:-1], bounds[1:], strict=True))
        futures = [
            self._pool.submit(reward, states[a:b], sensors[a:b], controls[a:b], *args)
            for a, b in spans
        ]
        parts = []
        for (a, b), future in zip(spans, futures, strict=True):
            try:
                part = np.asarray(future.result(), dtype=float)
            except (TypeError, ValueError) as err:
                raise JudoError(
                    f"reward must return ({b - a},) numbers for a block of {b - a} rows ({err})"
                ) from None
            if part.shape != (b - a,):
                raise JudoError(
                    f"reward returned shape {part.shape} for rows {a}:{b}, expected ({b - a},)"
                )
            parts.append(part)
        return np.concatenate(parts)

    def close(self) -> None:
        """End the threads (a later split call starts them again)."""
        if self._pool is not None:
            self._pool.shutdown(wait=False)
            self._pool = None
