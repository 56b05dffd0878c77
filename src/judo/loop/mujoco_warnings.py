"""MuJoCo's own warnings, counted into one log line every few seconds instead of one terminal line
each.

MuJoCo prints a warning (`mju_warning`, e.g. "Nan, Inf or huge value in QPOS at DOF 1") the first
time an MjData meets it. A planner's rollouts start each rollout afresh and a diverging plant is
reset every step, so a state MuJoCo cannot simulate makes a line per rollout: tens of thousands in a
few seconds. `count_mujoco_warnings()` hands MuJoCo's warnings (`mujoco.set_mju_user_warning`) to a
`WarningCounter`, which logs the first of each kind at once and then, at most every `REPORT_EVERY`
seconds, one line with how many came since; what is still uncounted at exit is said then. The
Systems that run MuJoCo or plan from a robot install it.
"""

import atexit
import logging
import math
import re
import threading
import time
from collections.abc import Callable

import mujoco

logger = logging.getLogger("judo.mujoco")

REPORT_EVERY = 5.0
"""Wall seconds between two lines that count MuJoCo's warnings."""
KINDS_NAMED = 3
"""Most kinds of warning one counting line names (the most frequent first)."""


class WarningCounter:
    """A handler for MuJoCo's warning texts that counts them into a log line every `report_every`
    seconds.

    Args:
        report_every: wall seconds between counting lines.
        clock: monotonic seconds.

    Attributes:
        total: warnings counted so far.
    """

    def __init__(
        self, report_every: float = REPORT_EVERY, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.report_every, self.clock = report_every, clock
        self.total = 0
        self._seen: set[str] = set()
        self._pending: dict[str, int] = {}  # kind -> warnings since the last line
        self._since = -math.inf  # when the last line was logged
        self._lock = threading.Lock()  # rollout threads warn at once

    def __call__(self, text: str) -> None:
        """Count MuJoCo's warning `text` (called by MuJoCo, from whichever thread warned)."""
        # the same warning at another time
        kind = re.sub(r"\s*Time = [-+.\deE]+\.?\s*$", "", text.strip())
        with self._lock:
            self.total += 1
            now = self.clock()
            if kind not in self._seen:
                self._seen.add(kind)
                self._since = now if not self._pending else self._since
                logger.warning(
                    "MuJoCo: %s (further MuJoCo warnings are counted every %g s)",
                    text,
                    self.report_every,
                )
                return
            self._pending[kind] = self._pending.get(kind, 0) + 1
            if now - self._since >= self.report_every:
                self._report(now)

    def flush(self) -> None:
        """Log the warnings counted since the last line, if any."""
        with self._lock:
            if self._pending:
                self._report(self.clock())

    def _report(self, now: float) -> None:
        count = sum(self._pending.values())
        kinds = sorted(self._pending.items(), key=lambda item: -item[1])
        named = "; ".join(f"{n:,} x {kind!r}" for kind, n in kinds[:KINDS_NAMED])
        more = f"; and {len(kinds) - KINDS_NAMED} more kinds" if len(kinds) > KINDS_NAMED else ""
        span = f"in the last {now - self._since:.0f} s" if math.isfinite(self._since) else "so far"
        logger.warning(
            "MuJoCo warned %s more times %s (%s total): %s%s",
            f"{count:,}",
            span,
            f"{self.total:,}",
            named,
            more,
        )
        self._pending.clear()
        self._since = now


_installed: WarningCounter | None = None


def count_mujoco_warnings() -> WarningCounter | None:
    """Hand MuJoCo's warnings to one `WarningCounter` for this process (once; later calls return
    it), and log what it still counts at exit. None, and nothing changed, where the process already
    gave MuJoCo a handler of its own."""
    global _installed
    current = mujoco.get_mju_user_warning()
    if current is not None and current is not _installed:
        return None
    if _installed is None:
        _installed = WarningCounter()
        atexit.register(_installed.flush)
    if current is None:
        mujoco.set_mju_user_warning(_installed)
    return _installed
