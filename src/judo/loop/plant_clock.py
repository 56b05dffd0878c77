"""The loop's two clocks: the plant clock (`PlantClock`), when a System's next `step()` is due in
wall time, and the control clock (`ControlClock`), when the next control update is due.

The plant clock steps a plant once per `timestep` of wall clock (docs/hardware.md). The app's plant
thread and `python -m judo excite` both pace a System by it.

Step k of a stretch is due at wall time origin + k * timestep, the origin being the wall time the
stretch began (its first step is due at once). `restart` ends the stretch: the next `due` begins a
new one (after a new session, a reset, a pause, a wait for the planner). A caller that falls further
behind than `max_catch_up` seconds at once falls behind instead: at most that many seconds of steps
are due at once, and the origin moves on by the rest, so a slow `step()` slows the plant down (the
real-time factor shows it) rather than bursting to catch up.

    clock = PlantClock()
    while running:
        now = time.perf_counter()
        due = clock.due(now, system.timestep)
        for _ in range(due):
            system.step()
        clock.stepped(due)
        time.sleep(clock.wait(time.perf_counter(), system.timestep))

The control clock is ticked in sim time by `ClosedLoop.step` (evaluate, tune, collect) and in wall
time by the app's planner runner. It ticks every 1 / control_freq s, read when asked (an edit takes
effect at once); an update whose plan takes effect after the next tick moves that tick to then,
since a controller cannot start a plan before the current one is done.
"""

import math
import time
from collections.abc import Callable

from judo.core.reading import TIME_TOLERANCE

MAX_CATCH_UP = 0.1
"""Most seconds of sim time due at once to catch up; beyond that the plant falls behind."""
STOP_POLL = 0.05
"""Most seconds `sleep_until_due` sleeps before it asks again whether to stop."""


class PlantClock:
    """Which steps of a plant are due at a wall time (time.perf_counter() seconds), and how long
    until the next.

    Args:
        max_catch_up: most seconds of steps due at once (at least one step).

    Attributes:
        running: whether a stretch runs (False before the first `due` and after `restart`).
    """

    def __init__(self, max_catch_up: float = MAX_CATCH_UP) -> None:
        self.max_catch_up = max_catch_up
        self.running = False
        self._origin = 0.0  # wall time step 0 of the stretch was due
        self._steps = 0  # steps taken in the stretch

    def restart(self) -> None:
        """End the stretch: the next `due` begins a new one, whose first step is due at once."""
        self.running = False

    def due(self, now: float, timestep: float) -> int:
        """Steps of `timestep` s due at wall time `now` and not taken yet, at most `max_catch_up` s
        of them (at least one); begins a stretch at `now` where none runs."""
        if not self.running:
            self._origin, self._steps, self.running = now, 0, True
        due = int((now - self._origin) / timestep) + 1 - self._steps
        most = max(1, round(self.max_catch_up / timestep))
        if due > most:  # too far behind to catch up: fall behind instead
            self._origin += (due - most) * timestep
            due = most
        return max(0, due)

    def stepped(self, count: int) -> None:
        """`count` more steps of the stretch were taken."""
        self._steps += count

    def wait(self, now: float, timestep: float) -> float:
        """Seconds from wall time `now` until the stretch's next step of `timestep` s is due (0 when
        it is due, or when no stretch runs)."""
        if not self.running:
            return 0.0
        return max(0.0, self._origin + self._steps * timestep - now)

    def sleep_until_due(self, timestep: float, stopped: Callable[[], bool]) -> bool:
        """Sleep until a step of `timestep` s is due (True), or until `stopped()` (False), asking it
        at least every STOP_POLL s: the wait of a caller that steps one step at a time."""
        while not stopped():
            now = time.perf_counter()
            if self.due(now, timestep):
                return True
            time.sleep(min(self.wait(now, timestep), STOP_POLL))
        return False


class ControlClock:
    """When the next control update is due.

    `restart(now)` makes an update due at `now`; `ticked(now, delay, period)` records an update made
    at `now` whose plan takes effect `delay` s later. Before the first restart every time is due.
    """

    def __init__(self) -> None:
        self._tick = -math.inf  # the time the latest update came due
        self._not_before = -math.inf  # when the latest update's plan takes effect

    def restart(self, now: float) -> None:
        """Make an update due at `now` (after a reset, whose time may start again, or a pause)."""
        self._tick, self._not_before = -math.inf, now

    def next_time(self, period: float) -> float:
        """The time the next update is due: one `period` after the latest tick, or when its plan
        takes effect if later."""
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
