"""Every call into a System, through one gate: which call is in flight and since when, and none after a stop.

A robot's driver may block or raise. The closed loop makes each System call through `SystemCalls`, so
- the app can see a call that has blocked for too long (`blocked`) and report it, or halt the robot;
- once `close()` has returned, no System call starts any more (a call already in flight may still end);
- each call fails on its own: the caller decides what a failed call means for the others.
"""

import threading
import time
from typing import Any

import numpy as np

from judo.core.errors import JudoError
from judo.loop.system import System, SystemState


class SystemClosedError(JudoError):
    """The app stopped: no System call starts any more."""


class SystemCallError(JudoError):
    """Some System calls of one plant step failed; each was tried on its own.

    Attributes:
        failed: {call name: its exception}, of "apply", "step" and "read_state".
    """

    def __init__(self, failed: dict[str, Exception]) -> None:
        self.failed = failed
        super().__init__(
            "; ".join(f"system {name} failed: {type(err).__name__}: {err}" for name, err in failed.items())
        )

    @property
    def served(self) -> bool:
        """Whether the plant still got its action and its step."""
        return "apply" not in self.failed and "step" not in self.failed


class SystemReadingError(JudoError, TypeError):
    """A System's `read_state()` returned something other than a SystemState."""


def check_reading(system: System, reading: Any) -> SystemState:
    """`reading`, which `system.read_state()` returned, if it is a SystemState; else SystemReadingError (one line,
    naming the System's class, the method and the expected type)."""
    if not isinstance(reading, SystemState):
        raise SystemReadingError(
            f"{type(system).__name__}.read_state() returned {type(reading).__name__}; expected a judo.SystemState "
            "(state, time, metadata, sensors)"
        )
    return reading


class SystemCalls:
    """Makes calls into `system` one gate at a time; safe to use from several threads.

    Attributes:
        system: the System called.
        in_flight: (name, monotonic start time) of the call under way, or None.
    """

    def __init__(self, system: System) -> None:
        self.system = system
        self.in_flight: tuple[str, float] | None = None
        self._gate = threading.Lock()
        self._closed = False

    def _call(self, name: str, *args: Any) -> Any:
        with self._gate:
            if self._closed:
                raise SystemClosedError(f"the app has stopped; System.{name} was not called")
            self.in_flight = (name, time.monotonic())
        try:
            return getattr(self.system, name)(*args)
        finally:
            self.in_flight = None

    def read_state(self) -> SystemState:
        return check_reading(self.system, self._call("read_state"))

    def apply(self, action: np.ndarray) -> None:
        self._call("apply", action)

    def step(self) -> None:
        self._call("step")

    def reset(self) -> None:
        self._call("reset")

    def halt(self) -> bool:
        """The System's `halt()`: True if it brought the robot to rest itself."""
        return bool(self._call("halt"))

    def offers_halt(self) -> bool:
        """Whether the System overrides `halt` (the default does nothing and returns False)."""
        return type(self.system).halt is not System.halt

    def blocked(self, limit: float) -> tuple[str, float] | None:
        """(name, seconds) of the call under way if it has run longer than `limit` seconds, else None."""
        in_flight = self.in_flight
        if in_flight is None:
            return None
        seconds = time.monotonic() - in_flight[1]
        return (in_flight[0], seconds) if seconds > limit else None

    def close(self) -> None:
        """Let no call start any more; returns at once (a call in flight is not waited for)."""
        with self._gate:
            self._closed = True

    @property
    def closed(self) -> bool:
        """Whether `close()` was called."""
        return self._closed
