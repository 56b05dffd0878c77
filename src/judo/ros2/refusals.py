"""`Refusals`: a robot link's tally of the readings it refused, logged once per kind, then every few
seconds.

A link that refuses a reading (a NaN, a wrong count, a stamp running back) says so without flooding
the log at the robot's rate: the first refusal of a kind is logged with its detail, later ones of
that kind at most every `REPORT_EVERY` seconds with the count so far. The ROS 2 and the Unitree
bridges each keep one.
"""

import logging
import math
import time

REPORT_EVERY = 5.0
"""Wall seconds between log lines of the same refusal."""


class Refusals:
    """Counts of refused readings by kind (`counts`), logged to `logger` as they come, rate-limited
    per kind."""

    def __init__(self, logger: logging.Logger) -> None:
        self.logger = logger
        self.counts: dict[str, int] = {}
        """{kind: readings refused so far}."""
        self._reported: dict[str, float] = {}

    def note(self, kind: str, detail: str) -> None:
        """Count one refusal of `kind`, and log it with `detail` unless that kind was logged less
        than REPORT_EVERY seconds ago."""
        self.counts[kind] = self.counts.get(kind, 0) + 1
        now = time.monotonic()
        if now - self._reported.get(kind, -math.inf) >= REPORT_EVERY:
            self._reported[kind] = now
            self.logger.warning("refused %s (%d so far): %s", kind, self.counts[kind], detail)

    def summary(self) -> str:
        """One phrase for an error: "3 refused (imu); 1 refused (odometry)", or "nothing
        arrived"."""
        return (
            "; ".join(f"{n} refused ({kind})" for kind, n in self.counts.items())
            or "nothing arrived"
        )
