"""The latched stop: once engaged, the plant is served the task's safe action (or held by the
System's own `halt()`) until an explicit clear, whatever plans come, and it outlives the process.

Who engages it: the GUI's Stop button and its key (Escape), SIGUSR1 to the app's process, a
std_msgs/Bool true on /judo/estop (the ROS 2 bridge), a robot bridge's own e-stop through
`wire_request` (the Unitree bridge), and `app.stop_latch.engage(source)` from a script. Who clears
it: the GUI's Clear stop button, /judo/estop false (`wire_request(False, source)`), and
`app.stop_latch.clear(source)`. A new plan, a reset, a task switch and a restart of the app leave it
as it is.

Persisted: while engaged, a small JSON file (`default_stop_file()`: $JUDO_STOP_FILE, else
$XDG_STATE_HOME/judo/stop.json, else ~/.local/state/judo/stop.json; the app's `--stop-file` names
another) says since when and by whom; a latch made on a path where the file exists starts engaged,
and a clear removes it. A file that cannot be read still engages (it says the robot was stopped; its
content is only the story).

Each engage and clear that changes the latch is a `StopEvent` (wall time, source, engaged) in
`StopLatch.events`; one that finds the latch as it is changes nothing (a wire that repeats "true"
ten times a second is one event). The closed loop (`judo.loop.closed_loop`) asks `latched` before
serving each action and calls `took_effect()` when it serves the stopped action, which stamps the
latest event with the seconds it took.
"""

import json
import logging
import os
import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from judo.core.commandline.boundary import check_output_file

logger = logging.getLogger("judo.safety")

STOP_FILE_OPTION = "the stop's state file (--stop-file, $JUDO_STOP_FILE)"
"""How a refused state file is named."""
STOP_FILE_ENV = "JUDO_STOP_FILE"
"""Environment variable naming the latched stop's state file (the default's default is the
user-state dir)."""
MAX_EVENTS = 1000
"""Most events a latch keeps (the latest ones), so a run that lasts for days stays bounded."""
UNHEARD_EVERY = 5.0
"""Seconds between log lines of wire requests that no latch listens to (a wire may repeat ten times
a second)."""


def default_stop_file() -> Path:
    """Where the latched stop is persisted: $JUDO_STOP_FILE, else $XDG_STATE_HOME/judo/stop.json,
    else ~/.local/state/judo/stop.json."""
    named = os.environ.get(STOP_FILE_ENV)
    if named:
        return Path(named).expanduser()
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "judo" / "stop.json"


@dataclass
class StopEvent:
    """One change of the latch.

    Attributes:
        time: wall-clock seconds since the epoch when it changed.
        source: who changed it ("GUI button", "SIGUSR1", "/judo/estop", "the state file ...", ...).
        engaged: True for a latch, False for a clear.
        effect_s: seconds from the change to the first action served under it (a latch only; None
            until then, and for a clear).
    """

    time: float
    source: str
    engaged: bool
    effect_s: float | None = None

    def line(self) -> str:
        """One line: "latched by SIGUSR1 at 02:51:03 UTC (in effect after 0.012 s)"."""
        when = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(self.time))
        what = "latched" if self.engaged else "cleared"
        effect = "" if self.effect_s is None else f" (in effect after {self.effect_s:.3f} s)"
        return f"{what} by {self.source} at {when}{effect}"


_open: "weakref.WeakSet[StopLatch]" = weakref.WeakSet()
_open_lock = threading.Lock()
# time.monotonic() of the last line logged of a request no latch listened to
_unheard_at = -float("inf")


class StopLatch:
    """A latched stop, safe to engage and clear from any thread (signal handlers, GUI callbacks, DDS
    readers).

    Args:
        path: its state file (None: kept in memory only, for a loop outside the app); a latch made
            where the file exists starts engaged. ConfigError at once for a path where no file can
            be written (a folder, a read-only place): a latch that cannot outlive the process would
            not keep its promise.
        on_change: called with each StopEvent, on the thread that made the change, outside the
            latch's lock, and once more with a latch's event when it took effect (its `effect_s`
            set, on the loop's thread).

    Attributes:
        latched: whether the stop is engaged; `engage` and `clear` set it under the latch's lock (a
            plain attribute, so the loop's read before each served action runs no code here).
        path: the state file.
        events: the changes so far (the latest MAX_EVENTS), the first one "the state file" when it
            started engaged.
    """

    def __init__(
        self, path: str | Path | None = None, on_change: Callable[[StopEvent], None] | None = None
    ) -> None:
        self.path = None if path is None else Path(path)
        check_output_file(STOP_FILE_OPTION, self.path)
        self.on_change = on_change
        self.events: list[StopEvent] = []
        self._lock = threading.Lock()
        self.latched = False
        # time.monotonic() of the latest latch, until it took effect
        self._since: float | None = None
        if self.path is not None and self.path.exists():
            self.latched = True  # served from the first step on: no time to take effect to measure
            self.events.append(self._persisted_event())

    @property
    def latest(self) -> StopEvent | None:
        """The latest change, or None."""
        return self.events[-1] if self.events else None

    def engage(self, source: str) -> bool:
        """Latch the stop (`source` says who); True if it was clear. Persisted before it returns."""
        with self._lock:
            if self.latched:
                return False
            self.latched, self._since = True, time.monotonic()
            event = self._add(StopEvent(time.time(), source, True))
            self._persist(event)
        self._tell(event)
        return True

    def clear(self, source: str) -> bool:
        """Clear the stop (`source` says who) and remove its state file; True if it was latched."""
        with self._lock:
            if not self.latched:
                return False
            self.latched, self._since = False, None
            event = self._add(StopEvent(time.time(), source, False))
            if self.path is not None:
                try:
                    self.path.unlink(missing_ok=True)
                except OSError as err:
                    logger.error(
                        "the stop is cleared, but its state file %s stays: %s", self.path, err
                    )
        self._tell(event)
        return True

    def took_effect(self) -> None:
        """Note that an action was served under the latch: the latest latch's `effect_s`, once (then
        told)."""
        if self._since is None:
            return
        with self._lock:
            since, self._since = self._since, None
            event = (
                self.events[-1]
                if since is not None and self.events and self.events[-1].engaged
                else None
            )
            if event is not None and since is not None:
                event.effect_s = time.monotonic() - since
        if event is not None:
            self._tell(event)

    def start_line(self) -> str:
        """What the app says at start when the latch is engaged: since when, and how to clear it."""
        latest = self.latest
        story = "" if latest is None else f", {latest.line()}"
        return (
            f"the stop is latched{story}: the plant is served the safe action until it is "
            "cleared with the GUI's "
            f"Clear stop button or std_msgs/Bool false on /judo/estop (or remove {self.path} "
            "before the next start)"
        )

    def listen(self) -> None:
        """Be reached by `wire_request` until `close()` (the app does so while it runs)."""
        with _open_lock:
            _open.add(self)

    def close(self) -> None:
        """No longer reached by `wire_request` (the app stopped); the latch and its file stay as
        they are."""
        with _open_lock:
            _open.discard(self)

    def _add(self, event: StopEvent) -> StopEvent:
        self.events.append(event)
        del self.events[:-MAX_EVENTS]
        return event

    def _persist(self, event: StopEvent) -> None:
        if self.path is None:
            return
        record = {"latched": True, "time": event.time, "source": event.source}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            part = self.path.with_name(self.path.name + ".part")
            part.write_text(json.dumps(record) + "\n")
            os.replace(part, self.path)
        except OSError as err:  # the latch holds in this process all the same
            logger.error(
                "the stop is latched, but its state file %s could not be written: %s",
                self.path,
                err,
            )

    def _persisted_event(self) -> StopEvent:
        """The latch the state file tells of, at its time (a file that cannot be read still latches,
        as of now)."""
        assert self.path is not None
        try:
            record = json.loads(self.path.read_text())
            return StopEvent(
                float(record["time"]), f"{record['source']} (from the state file {self.path})", True
            )
        except (OSError, ValueError, KeyError, TypeError) as err:
            return StopEvent(
                time.time(), f"the state file {self.path} (unreadable: {type(err).__name__})", True
            )

    def _tell(self, event: StopEvent) -> None:
        if self.on_change is None:
            logger.warning(
                "stop %s",
                event.line()
                if event.effect_s is None
                else f"in effect after {event.effect_s:.3f} s",
            )
        else:
            self.on_change(event)


def wire_request(engaged: bool, source: str) -> int:
    """A robot link's e-stop: engage (`engaged` True) or clear every listening StopLatch of this
    process (the running app's, `StopLatch.listen`), saying `source` (e.g. "/judo/estop", "the
    Unitree remote"). Returns how many latches changed.

    Call it from a System's thread whenever the wire says so; a repeated request changes nothing. A
    request while no app runs changes nothing either, and is logged (at most every UNHEARD_EVERY
    s)."""
    global _unheard_at
    with _open_lock:
        latches = list(_open)
        unheard = not latches and time.monotonic() - _unheard_at >= UNHEARD_EVERY
        if unheard:
            _unheard_at = time.monotonic()
    if unheard:
        logger.warning(
            "%s asked to %s the stop, but no app runs in this process",
            source,
            "engage" if engaged else "clear",
        )
    return sum(latch.engage(source) if engaged else latch.clear(source) for latch in latches)
