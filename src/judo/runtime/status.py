"""What a running app tells its user: the status line, the timing figures, and the end-of-run
summary.

- `StatusLine`: the latest message for the GUI, written to the log without flooding it;
- `Reports`: the status line worded with the session in use, for every part of the app;
- `RunStats` / `LiveFigures` / `RunSummary`: plan times, control rate, real-time factor, and the
  summary at exit.
"""

import logging
import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.configuration.registry import fitted_overrides
from judo.runtime.app_state import AppState
from judo.runtime.snapshots import Subscribers
from judo.safety.stop import StopEvent, StopLatch

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


@dataclass(frozen=True)
class RunSummary:
    """What `python -m judo --duration` prints at the end of a run.

    Attributes:
        task, optimizer: registry names in use at the end.
        sim_time: seconds of plant time stepped (pauses excluded).
        wall_time: wall-clock seconds the plant loop ran unpaused.
        num_plans: planning cycles completed.
        control_rate: planning cycles per wall-clock second.
        plan_time_mean_ms: mean wall time of one planning cycle over the whole run.
        plan_time_p95_ms: its 95th percentile over the last PLAN_TIMES_KEPT cycles.
        real_time_factor: sim_time / wall_time (1 = real time).
        final_reward: reward of the nominal rollout in the last cycle (NaN if none ran).
        stops: each latch and clear of the latched stop in the run (`judo.safety.stop`);
            stop_latched: still at exit.
    """

    task: str
    optimizer: str
    sim_time: float
    wall_time: float
    num_plans: int
    control_rate: float
    plan_time_mean_ms: float
    plan_time_p95_ms: float
    real_time_factor: float
    final_reward: float
    stops: tuple[StopEvent, ...] = ()
    stop_latched: bool = False
    limits: str | None = None
    """The [safety] limits' serve filter's line (commands filtered, replaced, hits by limit); None
    without limits."""

    def __str__(self) -> str:
        rows = [
            ("task", self.task),
            ("optimizer", self.optimizer),
            ("sim time", f"{self.sim_time:.2f} s in {self.wall_time:.2f} s wall"),
            ("control rate", f"{self.control_rate:.1f} Hz ({self.num_plans} plans)"),
            (
                "plan time",
                f"mean {self.plan_time_mean_ms:.2f} ms, p95 {self.plan_time_p95_ms:.2f} ms",
            ),
            ("real-time factor", f"{self.real_time_factor:.3f}"),
            (
                "final reward",
                f"{self.final_reward:.4g}"
                if np.isfinite(self.final_reward)
                else "none (no rollout scored)",
            ),
        ]
        rows += [("stop", event.line()) for event in self.stops]
        if self.stop_latched:
            rows.append(
                (
                    "stop",
                    "still latched at exit: the next start serves the safe action until it is "
                    "cleared",
                )
            )
        if self.limits is not None:
            rows.append(("limits", self.limits))
        return "\n".join(f"{name:>16}: {value}" for name, value in rows)


@dataclass(frozen=True)
class LiveFigures:
    """The figures the GUI plots, rates over the last `window` seconds; NaN where there is no data
    yet."""

    nominal_reward: float
    plan_time_ms: float
    control_rate: float
    real_time_factor: float


PLAN_TIMES_KEPT = 10_000
"""Plan times a RunStats keeps for the p95 (older ones only count towards the mean), so a long run's
memory stays bounded."""


class RunStats:
    """Collects plan and plant timings from the app's loops; safe to read from any thread.

    Memory is bounded however long the app runs: the last PLAN_TIMES_KEPT plan times, a count and a
    sum.
    """

    def __init__(self, window: float = 1.0) -> None:
        self.window = window
        self._lock = threading.Lock()
        self._plan_times: deque[float] = deque(maxlen=PLAN_TIMES_KEPT)
        self._num_plans = 0
        self._plan_time_total = 0.0
        self._recent_plan_starts: deque[float] = deque()
        self._first_plan_start: float | None = None
        self._last_plan_start: float | None = None
        self._nominal_reward = float("nan")
        self._sim_time = 0.0
        self._wall_time = 0.0
        self._recent_progress: deque[tuple[float, float]] = deque()  # (perf_counter, sim_time)

    def record_plan(self, start: float, duration: float, nominal_reward: float) -> None:
        """One planning cycle that began at `time.perf_counter()` value `start` and took `duration`
        s."""
        with self._lock:
            self._plan_times.append(duration)
            self._num_plans += 1
            self._plan_time_total += duration
            self._recent_plan_starts.append(start)
            if self._first_plan_start is None:
                self._first_plan_start = start
            self._last_plan_start = start
            self._nominal_reward = nominal_reward
            while self._recent_plan_starts[0] < start - self.window:
                self._recent_plan_starts.popleft()

    def record_plant(self, sim_dt: float, wall_dt: float) -> None:
        """The plant advanced `sim_dt` seconds of sim time during `wall_dt` unpaused wall-clock
        seconds."""
        now = time.perf_counter()
        with self._lock:
            self._sim_time += sim_dt
            self._wall_time += wall_dt
            self._recent_progress.append((now, self._sim_time))
            while (
                len(self._recent_progress) > 2 and self._recent_progress[1][0] < now - self.window
            ):
                self._recent_progress.popleft()

    def sim_time(self) -> float:
        """Seconds of plant time stepped so far."""
        with self._lock:
            return self._sim_time

    def num_plans(self) -> int:
        """Planning cycles completed so far."""
        with self._lock:
            return self._num_plans

    def live(self) -> LiveFigures:
        """The latest reward and plan time, and the rates over the last `window` seconds."""
        with self._lock:
            starts = self._recent_plan_starts
            rate = (len(starts) - 1) / (starts[-1] - starts[0]) if len(starts) > 1 else float("nan")
            plan_ms = 1000.0 * self._plan_times[-1] if self._plan_times else float("nan")
            rtf = float("nan")
            if len(self._recent_progress) > 1:
                (w0, s0), (w1, s1) = self._recent_progress[0], self._recent_progress[-1]
                rtf = (s1 - s0) / (w1 - w0) if w1 > w0 else float("nan")
            return LiveFigures(self._nominal_reward, plan_ms, rate, rtf)

    def summary(
        self, task: str, optimizer: str, stop: StopLatch | None = None, limits: str | None = None
    ) -> RunSummary:
        """Figures over the whole run so far, with the events of the latched `stop` and the `limits`
        line."""
        with self._lock:
            times, count = np.array(self._plan_times), self._num_plans
            span = 0.0
            if self._first_plan_start is not None and self._last_plan_start is not None:
                span = self._last_plan_start - self._first_plan_start
            return RunSummary(
                task=task,
                optimizer=optimizer,
                sim_time=self._sim_time,
                wall_time=self._wall_time,
                num_plans=count,
                control_rate=(count - 1) / span if span > 0 else float("nan"),
                plan_time_mean_ms=1000.0 * self._plan_time_total / count if count else float("nan"),
                plan_time_p95_ms=1000.0 * float(np.percentile(times, 95))
                if len(times)
                else float("nan"),
                real_time_factor=self._sim_time / self._wall_time
                if self._wall_time > 0
                else float("nan"),
                final_reward=self._nominal_reward,
                stops=() if stop is None else tuple(stop.events),
                stop_latched=stop is not None and stop.latched,
                limits=limits,
            )


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
        long it took). Every line is logged: the watchdog paces them (`judo.loop.watchdog`), and
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
