"""The app's status line: the latest message for the GUI, written to the log without flooding it."""

import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Literal

logger = logging.getLogger("judo.app")

REPEAT_LOG_INTERVAL = 5.0
"""Seconds before the same status message is written to the log again."""

Level = Literal["info", "warning", "error"]


@dataclass(frozen=True)
class Status:
    """The GUI's status line: the latest message, its level, and a count that grows with each report."""

    message: str
    level: Level
    count: int


class StatusLine:
    """The latest status, safe to report from any thread.

    Each message is logged at most once every REPEAT_LOG_INTERVAL seconds, however messages alternate.
    Parts of the app that failed (`trouble`) are remembered until they report a recovery.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.status = Status("starting", "info", 0)
        self._logged_at: dict[str, float] = {}
        self.trouble: set[str] = set()

    def report(self, message: str, level: Level = "info", log: bool = True) -> None:
        """Show `message` and write it to the log (each message at most once every REPEAT_LOG_INTERVAL s; never
        without `log`, for a count that changes every second)."""
        with self._lock:
            self.status = Status(message, level, self.status.count + 1)
            now = time.monotonic()
            if not log:
                return
            if now - self._logged_at.get(message, -math.inf) < REPEAT_LOG_INTERVAL:
                return
            if len(self._logged_at) >= 64:  # forget messages not logged lately, so the table stays small
                self._logged_at = {m: t for m, t in self._logged_at.items() if now - t < REPEAT_LOG_INTERVAL}
            self._logged_at[message] = now
        logger.log({"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}[level], message)

    def failed(self, part: str, message: str, level: Level = "error") -> None:
        """Report that `part` (e.g. "planner") failed; it stays in trouble until `recovered`."""
        self.trouble.add(part)
        self.report(message, level)

    def recovered(self, part: str, message: str) -> None:
        """After a success of `part`: if its failure is on the status line, replace it with `message`."""
        if part not in self.trouble:
            return
        self.trouble.discard(part)
        if self.status.level != "info":
            self.report(message)
