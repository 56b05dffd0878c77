"""What a running app tells its user in words: the status line, and the reports of every part.

- `StatusLine`: the latest message for the GUI, written to the log without flooding it;
- `Reports`: the status line worded with the session in use, for every part of the app.

The run's figures (plan times, control rate, real-time factor, the summary at exit) are
`judo.runtime.snapshots.RunStats`'.
"""

import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Literal

from judo.core.configuration.registry import fitted_overrides
from judo.runtime.app_state import AppState
from judo.runtime.snapshots import Subscribers
from judo.safety.stop import StopEvent

logger = logging.getLogger("judo.app")

REPEAT_LOG_INTERVAL = 5.0
"""Seconds before the same status message is written to the log again."""

Level = Literal["info", "warning", "error"]


@dataclass(frozen=True)
class Status:
    """The GUI's status line: the latest message, its level, and a count that grows with each
    report."""

    message: str
    level: Level
    count: int


class StatusLine:
    """The latest status, safe to report from any thread.

    Each message is logged at most once every REPEAT_LOG_INTERVAL seconds, however messages
    alternate. Parts of the app that failed (`trouble`) are remembered until they report a recovery.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.status = Status("starting", "info", 0)
        self._logged_at: dict[str, float] = {}
        self.trouble: set[str] = set()
        self.changed = Subscribers()  # (status) after each report, on the reporting thread

    def report(
        self, message: str, level: Level = "info", log: bool = True, paced: bool = False
    ) -> None:
        """Show `message` and write it to the log (each message at most once every
        REPEAT_LOG_INTERVAL s, or every time where its sender paces its reports itself, `paced`;
        never without `log`, for a count that changes every second)."""
        with self._lock:
            self.status = status = Status(message, level, self.status.count + 1)
            now = time.monotonic()
            logged = log and (
                paced or now - self._logged_at.get(message, -math.inf) >= REPEAT_LOG_INTERVAL
            )
            if logged:
                # forget messages not logged lately, so the table stays small
                if len(self._logged_at) >= 64:
                    self._logged_at = {
                        m: t for m, t in self._logged_at.items() if now - t < REPEAT_LOG_INTERVAL
                    }
                self._logged_at[message] = now
        self.changed.fire(status)  # outside the lock: a callback may report
        if not logged:
            return
        logger.log(
            {"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}[level],
            message,
        )

    def failed(self, part: str, message: str, level: Level = "error") -> None:
        """Report that `part` (e.g. "planner") failed; it stays in trouble until `recovered`."""
        self.trouble.add(part)
        self.report(message, level)

    def recovered(self, part: str, message: str) -> None:
        """After a success of `part`: if its failure is on the status line, replace it with
        `message`."""
        if part not in self.trouble:
            return
        self.trouble.discard(part)
        if self.status.level != "info":
            self.report(message)


class Reports:
    """Reports to the app's status line (and the log) from any thread.

    Args:
        line: the status line the GUI shows.
        state: the app's state, for the names of the session in use.
    """

    def __init__(self, *, line: StatusLine, state: AppState) -> None:
        self.line, self._state = line, state

    @property
    def status(self) -> Status:
        """The latest status message."""
        return self.line.status

    def report(self, message: str, level: Level = "info") -> None:
        """Show `message` (each message logged at most once every few seconds)."""
        self.line.report(message, level)

    def progress(self, message: str, level: Level = "info") -> None:
        """Show `message` without writing it to the log (a count that changes every second)."""
        self.line.report(message, level, log=False)

    def failed(self, part: str, message: str, level: Level = "error") -> None:
        """`part` (e.g. "planner") failed; it stays in trouble until it recovers."""
        self.line.failed(part, message, level)

    def recovered(self, part: str, news: str) -> None:
        """`part` works again: say `news` and that the app is running, if its failure is on the
        status line (the line is worded only then: a runner calls this after each success)."""
        if part in self.line.trouble:
            self.line.recovered(part, f"{news}: {self.running()}")

    def running(self) -> str:
        """'running TASK with OPTIMIZER', and where the planning model has model overrides
        ([model_overrides.TASK]), ', planning with a fitted model (body_mass.pole, ...)' when sysid
        fitted them all (its fitted.toml says so in [sysid.TASK]), else ', planning with a model
        with overrides (dof_damping.slider, ...)'."""
        session = self._state.session
        message = f"running {session.task_name} with {session.optimizer_name}"
        entries = [
            f"{f}.{e}"
            for f, values in session.controller.task.model_overrides.items()
            for e in values
        ]
        # no overrides: none to look up
        fitted = fitted_overrides(session.task_name) if entries else frozenset()
        if entries and all(entry in fitted for entry in entries):
            message += f", planning with a fitted model ({', '.join(entries)})"
        elif entries:
            shown = [f"{entry} fitted by sysid" if entry in fitted else entry for entry in entries]
            message += f", planning with a model with overrides ({', '.join(shown)})"
        return message

    def on_stop(self, event: StopEvent) -> None:
        """The latched stop was latched or cleared (`judo.safety.stop`): say so, and tell the
        recording under way; then say when a latch took effect (the first safe action served under
        it)."""
        if event.effect_s is not None:
            self.line.report(
                f"stop in effect after {event.effect_s:.3f} s: serving the safe action",
                "warning",
                paced=True,
            )
            return
        if event.engaged:
            self.line.report(
                f"stop {event.line()}: serving the safe action until it is cleared",
                "warning",
                paced=True,
            )
        else:
            self.line.report(f"stop {event.line()}: {self.running()}", paced=True)
        recording = self._state.recording
        if recording is not None:
            recording.on_config(
                "stop", None, source=event.source, engaged=event.engaged, wall_time=event.time
            )

    def on_watchdog(self, reason: str | None) -> None:
        """The closed loop's watchdog serves the safe action (`reason`, at the start of a trouble
        and every few seconds while it lasts) or fresh plans again (None, once per trouble, with how
        long it took). Every line is logged: the watchdog paces them (`judo.loop.timing`), and
        each trouble told is paired with its end."""
        if reason is not None:
            self.line.trouble.add("watchdog")
            self.line.report(f"watchdog: {reason}; serving the safe action", "warning", paced=True)
            return
        self.line.trouble.discard("watchdog")  # said even when another part's recovery came first
        watchdog = self._state.session.closed_loop.watchdog
        resumed = (
            ""
            if watchdog.resumed_s is None
            else (f", {watchdog.resumed_s:.2f} s after the readings resumed")
        )
        news = (
            f"fresh plans are served again after {watchdog.episode_s:.2f} s of the safe "
            f"action{resumed}"
        )
        self.line.report(f"{news}: {self.running()}", paced=True)
