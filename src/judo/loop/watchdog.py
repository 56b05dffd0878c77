"""The watchdog on the served action: how fresh the readings and the plan in force are.

Ages are measured on the closed loop's clock: in `evaluate` and `tune` the plant time the loop has stepped,
in the app the wall clock. A reading is fresh when its time advanced past the one before; a plan is as old
as the freshest reading it was planned from. Once the plan in force is older than `max_plan_age` beyond one
control period, the plant is served the task's `safe_action` until a fresh plan arrives. The plan may be
old because planning stalled (a hung reward, a 4 s cycle), failed (a reward that raises, a NaN or
wrong-shape reading), was cancelled, or last read a reading whose time did not advance (a frozen sensor
stream). A reading whose time goes backwards is refused.
"""

import math
import threading
import time

from judo.core.errors import JudoError
from judo.loop.system import SystemState

TIME_TOLERANCE = 1e-9
"""Seconds within which two reading times count as the same."""


class ReadingTimeError(JudoError):
    """A reading's time went backwards (a System's clock must never run back); the reading is refused."""


class Watchdog:
    """Freshness of the readings and of the plan in force, on the loop's clock.

    Attributes:
        fresh_at: clock time at which the latest reading's time last advanced.
        tripped: why the safe action is being served, or None while plans are fresh.
        trips: episodes of trouble so far (each trip counts once until plans are fresh again).
    """

    def __init__(self) -> None:
        self.fresh_at = 0.0
        self.tripped: str | None = None
        self.trips = 0
        self._last_time: float | None = None

    def restart(self, now: float) -> None:
        """Start afresh at clock time `now` (after a reset of the plant, whose time may start again at 0)."""
        self.fresh_at, self._last_time, self.tripped = now, None, None

    def note_reading(self, reading: SystemState, now: float) -> None:
        """Stamp `reading` at clock time `now`: fresh if its time advanced. Raises ReadingTimeError if its
        time went backwards, and keeps the stamps as they were."""
        time = reading.time
        if not math.isfinite(time):  # never fresh; planning refuses it anyway
            return
        if self._last_time is not None and time < self._last_time - TIME_TOLERANCE:
            raise ReadingTimeError(
                f"refused a reading whose time went backwards, from {self._last_time:.6g} s to {time:.6g} s; "
                "a System's read_state().time must never decrease (reset the plant to start it again)"
            )
        if self._last_time is None or time > self._last_time + TIME_TOLERANCE:
            self.fresh_at = now
        self._last_time = time

    def verdict(self, now: float, plan_stamp: float, max_plan_age: float, control_freq: float) -> str | None:
        """Why the plan stamped `plan_stamp` must not be served at clock time `now`, or None if it may.

        Updates `tripped` and `trips`. `max_plan_age` 0 turns the watchdog off.
        """
        if max_plan_age <= 0:
            self.tripped = None
            return None
        limit = max_plan_age + 1.0 / control_freq
        age = now - plan_stamp
        if age <= limit:
            self.tripped = None
            return None
        if now - self.fresh_at > limit:
            reason = f"the readings' time has not advanced for {now - self.fresh_at:.2f} s (a frozen sensor stream?)"
        else:
            reason = f"the plan in force is {age:.2f} s old (planning stalled or failed)"
        if self.tripped is None:
            self.trips += 1
        self.tripped = reason
        return reason


class PausableClock:
    """Wall-clock seconds (monotonic) that stand still while paused: the app's watchdog clock, so a pause
    does not age the plan in force."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._paused_at: float | None = None
        self._paused_for = 0.0

    def __call__(self) -> float:
        with self._lock:
            now = self._paused_at if self._paused_at is not None else time.monotonic()
            return now - self._paused_for

    def pause(self) -> None:
        with self._lock:
            if self._paused_at is None:
                self._paused_at = time.monotonic()

    def resume(self) -> None:
        with self._lock:
            if self._paused_at is not None:
                self._paused_for += time.monotonic() - self._paused_at
                self._paused_at = None
