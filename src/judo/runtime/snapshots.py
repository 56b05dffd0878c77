"""What the app's loops publish in the StateBuffer for the GUI and scripts: plant readings and
plans.

`StateBuffer` is the one place the app's loops exchange data: the latest value of each topic, as a
versioned snapshot.

A writer publishes a value; the buffer stores a deep copy whose arrays are read-only, under a lock,
and stamps it with the next version number. A reader gets that stored snapshot whole. Since a
published snapshot is never written again, a reader can never see half of one write and half of
another (no torn reads), however the threads interleave.

A reader that wants each snapshot as it comes subscribes (`subscribe(topic, callback)`): the
callback runs on the publisher's thread (the plant's or the planner's) right after the snapshot is
stored. `Subscribers` holds the callbacks of one event for the app's other news (config changes,
resets, switches). A callback must be cheap: keep the newest value and let its own thread act on it;
one that raises is logged and the publisher goes on.
"""

import copy
import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from judo.core.reading import SystemState


@dataclass(frozen=True)
class SystemSnapshot:
    """What the system loop publishes under "system": the plant reading of one session.

    Attributes:
        generation: the session that read it.
        reading: the state the next plan starts from: the estimate when an estimator runs, else the
            reading.
        true_state: (nq + nv,) the simulated plant's true state when an estimator runs (the GUI
            draws it as the robot and the estimate as a ghost); None otherwise, and for a user's
            System.
    """

    generation: int
    reading: SystemState
    true_state: np.ndarray | None = None


@dataclass(frozen=True)
class PlanSnapshot:
    """What the controller loop publishes under "plan" after each planning cycle.

    Attributes:
        generation: the session that planned.
        time: sim time of the state planned from.
        nominal_knots: (num_nodes, nu) knots of the new plan.
        rewards: (num_rollouts,) rewards of the last iteration (index 0 is the nominal).
        traces: (1 + num_shown, T, num_trace_sensors, 3) trace-sensor positions, nominal first.
        plan_time: wall-clock seconds the cycle took.
        resets: plant resets done before the state planned from was read; a plan from before the
            latest reset is stale, and the GUI never draws its traces over the reset plant.
    """

    generation: int
    time: float
    nominal_knots: np.ndarray
    rewards: np.ndarray
    traces: np.ndarray
    plan_time: float
    resets: int = 0


T = TypeVar("T")

logger = logging.getLogger("judo.app")


class Subscribers:
    """The callbacks of one event, called in the order added on the thread that fires it."""

    def __init__(self) -> None:
        self._callbacks: tuple[Callable[..., None], ...] = ()
        self._lock = threading.Lock()

    def add(self, callback: Callable[..., None]) -> None:
        """Call `callback` with the event's arguments each time it fires, from now on."""
        with self._lock:
            self._callbacks = (*self._callbacks, callback)

    def fire(self, *args: Any) -> None:
        """Call every callback with `args`; one that raises is logged, and the others are still
        called."""
        for callback in self._callbacks:
            try:
                callback(*args)
            except Exception:
                logger.exception("a subscriber's callback failed")


@dataclass(frozen=True)
class Snapshot(Generic[T]):
    """One published value.

    Attributes:
        version: position of this publication among all of the buffer's, counting from 1.
        value: a private deep copy of what was published; its numpy arrays are read-only.
        wall_time: `time.perf_counter()` when it was published.
    """

    version: int
    value: T
    wall_time: float


class StateBuffer:
    """Latest snapshot per topic (e.g. "system", "plan"), safe to share between threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._latest: dict[str, Snapshot[Any]] = {}
        self._version = 0
        self._subscribers: dict[str, Subscribers] = {}

    def subscribe(self, topic: str, callback: Callable[[Snapshot[Any]], None]) -> None:
        """Call `callback(snapshot)` with each snapshot of `topic` published from now on, on the
        publisher's thread."""
        with self._lock:
            subscribers = self._subscribers.setdefault(topic, Subscribers())
        subscribers.add(callback)

    def publish(self, topic: str, value: T) -> Snapshot[T]:
        """Store a frozen copy of `value` as the newest snapshot of `topic` and return it.

        The copy is made before taking the lock, so the caller may reuse or change `value` at once.
        """
        frozen = _freeze(copy.deepcopy(value))
        with self._lock:
            self._version += 1
            snapshot = Snapshot(self._version, frozen, time.perf_counter())
            self._latest[topic] = snapshot
            subscribers = self._subscribers.get(topic)
        if subscribers is not None:
            subscribers.fire(snapshot)
        return snapshot

    def latest(self, topic: str) -> Snapshot[Any] | None:
        """The newest snapshot of `topic`, or None if nothing was published to it yet."""
        with self._lock:
            return self._latest.get(topic)

    def clear(self, topic: str) -> None:
        """Forget `topic`, e.g. the old plan after a switch of task."""
        with self._lock:
            self._latest.pop(topic, None)


def _freeze(value: Any) -> Any:
    """Mark every numpy array reachable through dicts, lists, tuples and dataclasses read-only."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, dict):
        for item in value.values():
            _freeze(item)
    elif isinstance(value, (list, tuple)):
        for item in value:
            _freeze(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _freeze(getattr(value, f.name))
    return value
