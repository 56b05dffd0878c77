"""A robot's header stamps as reading times that never run back, whatever the link does to them.

A stamp older than the last accepted one (a late, reordered message) or further ahead of it than the
wall time since allows (a clock that jumped) is refused. Stamps refused consistently for
`RESTART_AFTER` seconds are the robot's new clock (its process restarted): they are accepted from
then on, the reading times carried on from where they were.
"""

import logging
import math

logger = logging.getLogger("judo.ros2")

RESTART_AFTER = 1.0
"""Wall seconds of stamps refused as backwards or from the future before they count as the robot's
new clock."""
FUTURE_TOLERANCE = 0.5
"""Seconds a stamp may run ahead of the last one plus the wall time since, before it counts as from
the future."""


class RobotClock:
    """Turns a robot's header stamps into reading times that never run back."""

    def __init__(self) -> None:
        self.last_stamp: float | None = None
        self.last_time = 0.0
        self._last_wall = 0.0
        self._epoch = 0.0  # reading time - stamp, moved when the robot's clock restarts
        self._refused_since: float | None = None

    def accept(self, stamp: float, wall: float) -> tuple[float | None, str | None]:
        """(reading time, None) for an accepted `stamp` (seconds) received at `wall` (monotonic
        seconds), or (None, why it was refused)."""
        if not math.isfinite(stamp):
            return None, f"a non-finite stamp {stamp}"
        last = self.last_stamp
        why = None
        if last is not None:
            if stamp < last - 1e-9:
                why = f"a stamp that went backwards, from {last:.3f} s to {stamp:.3f} s"
            elif stamp > last + (wall - self._last_wall) + FUTURE_TOLERANCE:
                why = (
                    f"a stamp from the future: {stamp:.3f} s, {stamp - last:.3f} s after "
                    f"{last:.3f} s"
                )
        if why is not None:
            if self._refused_since is None:
                self._refused_since = wall
            if wall - self._refused_since < RESTART_AFTER:
                return None, why
            # the robot's clock restarted: carry on from here
            carried = self.last_time + (wall - self._last_wall)
            self._epoch = carried - stamp
            logger.warning(
                "the robot's clock restarted (%s); readings go on from %.3f s", why, carried
            )
        self._refused_since = None
        self.last_stamp, self._last_wall = stamp, wall
        self.last_time = stamp + self._epoch
        return self.last_time, None
