"""The control clock: when the next control update is due, in one time base.

One clock serves both schedulers: `ClosedLoop.step` ticks it in sim time (evaluate, tune, collect), and the
app's planner runner (`judo.runtime.planner_runner`) in wall time.

The clock ticks every 1 / control_freq s. An update that overran its tick (its plan takes effect later than the
next tick: a delay longer than the period) moves the next tick to when its plan takes effect, since a controller
cannot start a plan before the current one is done. The period is read when the clock is asked, so an edit of
control_freq takes effect at once.
"""

import math

TIME_TOLERANCE = 1e-9
"""Seconds within which two times count as the same (an update due at t is due at t)."""


class ControlClock:
    """When the next control update is due.

    `restart(now)` makes an update due at `now`; `ticked(now, delay, period)` records an update made at `now`
    whose plan takes effect `delay` s later. Before the first restart every time is due.
    """

    def __init__(self) -> None:
        self._tick = -math.inf  # the time the latest update came due
        self._not_before = -math.inf  # when the latest update's plan takes effect

    def restart(self, now: float) -> None:
        """Make an update due at `now` (after a reset, whose time may start again, or a pause)."""
        self._tick, self._not_before = -math.inf, now

    def next_time(self, period: float) -> float:
        """The time the next update is due: one `period` after the latest tick, or when its plan takes effect
        if later."""
        return max(self._tick + period, self._not_before)

    def due(self, now: float, period: float) -> bool:
        """Whether an update is due at `now`."""
        return now >= self.next_time(period) - TIME_TOLERANCE

    def ticked(self, now: float, delay: float, period: float) -> None:
        """An update came due and was made at `now`; its plan takes effect at `now + delay`."""
        self._tick, self._not_before = self.next_time(period), now + delay

    def remaining(self, now: float, period: float) -> float:
        """Seconds from `now` until the next update is due (0 when it is due)."""
        return max(0.0, self.next_time(period) - now)
