"""The watchdog: how fresh the readings and the plan in force are, and what to tell about it.

The closed loop (`judo.loop.closed_loop`) asks `Watchdog.verdict` before serving each action, on the
loop's clock (plant time in evaluate and tune, the wall clock in the app). A reading is fresh when
its time advanced past the one before (one that goes backwards is refused); a plan is as old as the
freshest reading it was planned from. Once the plan in force is older than `max_plan_age` beyond one
control period, the plant is served the task's `safe_action` until a fresh plan is served.

The plan's age is two parts: how long the readings have stood still, and how far the newest plan
lags behind the freshest reading. The larger part is named as the cause:
- the readings stopped (a dead or paused robot, its driver, the link, a frozen sensor stream): the
  planner has planned from the latest reading, and that reading is old;
- planning stalled or failed (a hung or raising reward, a cycle slower than the bound, a refused
  reading): fresher readings came than any plan was made from.

What is told (`news`, read after each verdict): the trouble when it starts, when it turns out to be
the readings that stopped, and every REPORT_EVERY s of the clock while it lasts (its reason says for
how long); then its end, once, with how long the safe action was served (`episode_s`) and how long
after the readings resumed (`resumed_s`). A trouble that starts within REPORT_EVERY s of the last
one told, for the same cause (a planner that is slow by turns), is counted instead, and the next
line told says how many; its end is told only if its start was.
"""

import math

import numpy as np

from judo.core.errors import JudoError
from judo.core.reading import TIME_TOLERANCE, SystemState
from judo.core.task import Task

REPORT_EVERY = 5.0
"""Seconds of the watchdog's clock between two lines told of the same trouble."""
READINGS_STOPPED = "the readings stopped"
"""How a reason that blames the readings begins."""
PLANNING_LATE = "the plan in force is"
"""How a reason that blames planning begins."""


class ReadingTimeError(JudoError):
    """A reading's time went backwards (a System's clock must never run back); the reading is
    refused."""


class Watchdog:
    """Freshness of the readings and of the plan in force, on the loop's clock.

    Attributes:
        fresh_at: clock time at which the latest reading's time last advanced.
        tripped: why the safe action is being served, or None while plans are fresh.
        trips: episodes of trouble so far (each trip counts once until plans are fresh again).
        news: whether the latest verdict is to be told (see the module's docstring): its reason, or
            None for the end of a trouble that was told.
        episode_s: clock seconds the latest trouble has lasted (while it lasts) or lasted (once it
            ended).
        resumed_s: clock seconds from the readings' resuming to the end of the latest trouble, where
            they had stopped during it; None otherwise.
    """

    def __init__(self) -> None:
        self.fresh_at = 0.0
        self.tripped: str | None = None
        self.trips = 0
        self.news = False
        self.episode_s = 0.0
        self.resumed_s: float | None = None
        self._last_time: float | None = None
        self._began = 0.0  # clock time the trouble began
        self._cause: str | None = None  # READINGS_STOPPED or PLANNING_LATE, while tripped
        self._readings_stopped = False  # the readings stood still during this trouble
        self._resumed_at: float | None = None  # clock time they advanced again during it
        self._told_at, self._told_cause = -math.inf, None  # the last line told of a trouble
        self._told = False  # this trouble's start was told
        self._untold = 0  # troubles begun and ended untold since the last line told

    def restart(self, now: float) -> None:
        """Start the readings' freshness afresh at clock time `now` (after a reset of the plant,
        whose time may start again at 0). A trouble under way stays until the next verdict finds the
        plan fresh."""
        self.fresh_at, self._last_time = now, None

    def note_reading(self, reading: SystemState, now: float) -> None:
        """Stamp `reading` at clock time `now`: fresh if its time advanced. Raises ReadingTimeError
        if its time went backwards, and keeps the stamps as they were."""
        time = reading.time
        if not math.isfinite(time):  # never fresh; planning refuses it anyway
            return
        if self._last_time is not None and time < self._last_time - TIME_TOLERANCE:
            raise ReadingTimeError(
                f"refused a reading whose time went backwards, from {self._last_time:.6g} s "
                f"to {time:.6g} s; "
                "a System's read_state().time must never decrease (reset the plant to start "
                "it again)"
            )
        if self._last_time is None or time > self._last_time + TIME_TOLERANCE:
            if self._readings_stopped and self._resumed_at is None:
                self._resumed_at = now
            self.fresh_at = now
        self._last_time = time

    def verdict(
        self,
        now: float,
        plan_stamp: float,
        max_plan_age: float,
        control_freq: float,
        newest_stamp: float | None = None,
    ) -> str | None:
        """Why the plan stamped `plan_stamp` must not be served at clock time `now`, or None if it
        may.

        `newest_stamp` is the stamp of the newest plan made (served or still to take effect;
        `plan_stamp` if None): how far it lags behind the freshest reading is planning's share of
        the age. Updates `tripped`, `trips`, `news`, `episode_s` and `resumed_s`. `max_plan_age` 0
        turns the watchdog off.
        """
        age = now - plan_stamp
        if max_plan_age <= 0 or age <= max_plan_age + 1.0 / control_freq:
            self._clear(now)
            return None
        stood = now - self.fresh_at  # how long the readings have stood still
        lag = self.fresh_at - max(plan_stamp, plan_stamp if newest_stamp is None else newest_stamp)
        if stood > lag:
            cause = READINGS_STOPPED
            reason = (
                f"{READINGS_STOPPED}: their time has not advanced for {stood:.2f} s "
                "(is the robot, its driver or the link down, or the sensor stream frozen?)"
            )
        else:
            cause = PLANNING_LATE
            reason = f"{PLANNING_LATE} {age:.2f} s old (planning stalled or failed)"
        self._trip(now, cause)
        if self.news and self._untold:
            reason += (
                f" ({self._untold} shorter episode{'s' if self._untold > 1 else ''} since the "
                "last report)"
            )
            self._untold = 0
        self.tripped = reason
        return reason

    def _trip(self, now: float, cause: str) -> None:
        """Note trouble of `cause` at `now`, and whether it is news."""
        # a new trouble: told unless one of the same cause was told just now
        if self.tripped is None:
            self.trips += 1
            self._began, self._readings_stopped, self._resumed_at = now, False, None
            self._told = cause != self._told_cause or now - self._told_at >= REPORT_EVERY
            self.news = self._told
            if not self._told:
                self._untold += 1
        else:  # told again when the readings turn out to have stopped, and every REPORT_EVERY s
            self.news = (
                cause != self._cause and cause == READINGS_STOPPED
            ) or now - self._told_at >= REPORT_EVERY
            # a trouble counted untold lasted: it is told after all
            if self.news and not self._told:
                self._told, self._untold = True, max(0, self._untold - 1)
        if cause == READINGS_STOPPED:
            self._readings_stopped, self._resumed_at = True, None
        self._cause, self.episode_s = cause, now - self._began
        if self.news:
            self._told_at, self._told_cause = now, cause

    def _clear(self, now: float) -> None:
        """Plans are fresh at `now`: the end of a trouble is news if its start was told."""
        self.news = self.tripped is not None and self._told
        if self.tripped is not None:
            self.episode_s = now - self._began
            self.resumed_s = None if self._resumed_at is None else now - self._resumed_at
        self.tripped, self._cause, self._told = None, None, False


def safe_action(task: Task, state: np.ndarray | None) -> np.ndarray:
    """(command_size,) what the watchdog serves: the task's `safe_action` from the (nq + nv,)
    `state`, the latest finite reading (the planning model's start state when None), clamped to the
    command range."""
    if state is None:
        model = task.model
        state = np.concatenate(
            [model.key_qpos[0] if model.nkey else model.qpos0, np.zeros(model.nv)]
        )
    low, high = task.command_range.T
    return np.clip(np.asarray(task.safe_action(state), dtype=float), low, high)
