"""What the closed loop asks of the two things that may override the plan it serves, handed in by
its builder.

- a `Guard` (`ClosedLoop(guard=...)`): every served action passes its `filter`, and the step's
  record keeps its `step_hits`; the owner's limits build one
  (`judo.safety.serve_filter.safety_guard`, `judo.safety_guard`);
- a `Stop` (`ClosedLoop(stop=...)`): while it is `latched` the plant is served the safe action (or
  held by the System's halt); `judo.safety.stop.StopLatch` is one.
The loop imports neither: it types them by these protocols.
"""

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

__all__ = ["Guard", "Stop"]


class Guard(Protocol):
    """The last-line filter of every served action (the owner's limits).

    Attributes:
        step_hits: what acted on the latest filtered action (recorded in its StepRecord's
            `limit_hits`).
    """

    @property
    def step_hits(self) -> tuple[Any, ...]: ...

    def filter(
        self,
        action: np.ndarray,
        state: np.ndarray | None,
        time: float,
        safe_action: Callable[[], np.ndarray],
        metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """(nu,) the action to serve at plant `time` instead of `action`, from the latest reading's
        (nq + nv,) `state` (None where the plant gives none) and `metadata`; `safe_action()` is the
        task's safe action."""
        ...


class Stop(Protocol):
    """A latched stop: while `latched`, the loop serves the safe action whatever plans come."""

    @property
    def latched(self) -> bool: ...

    def took_effect(self) -> None:
        """Called when an action was served under the latch."""
        ...
