"""What the app's threads run on together: the stop they all poll, the planning cycle in flight
(its cancel and its cost), the `StateBuffer` the plant's readings and the plans are published in,
and the run's figures (`RunStats`). The values published and shown are `judo.runtime.snapshots`'.

`StopSignal` is the app's stop (`AppState.stop`), set from any thread (`App.stop()`, Ctrl-C,
SIGTERM, the duration reached, a dead plant thread). Threads see it with `is_set` / `wait`; the
event loop's coroutines sleep with `sleep` and run blocking calls with `in_worker`, both of which
return, or raise `Stopping`, as soon as it is set.

The planner runner plans under a `PlanningCycle`: the controller polls it (`is_set`) between
optimizer iterations and the CPU rollout pool between pieces of a batch, so a pause, reset, switch
or resize that cancels it ends it within a fraction of a second, keeping the plan before. A cycle's
cost is its rollout steps (`CycleSize`: num_rollouts x num_randomizations x iterations x T) times
the seconds one step takes on the session's backend (`StepCost`): probed on the planning model,
then measured from each completed cycle large enough for its fixed overhead not to count. The
commands refuse an edit whose estimated cycle exceeds MAX_CYCLE_SECONDS, and the GUI shows the cost.

`StateBuffer` is the one place the app's loops exchange data: the latest value of each topic, as a
versioned snapshot. A writer publishes a value; the buffer stores a deep copy whose arrays are
read-only, so a reader never sees half of one write and half of another. A reader that wants each
snapshot as it comes subscribes: the callback runs on the publisher's thread right after the
snapshot is stored; it must be cheap (keep the newest value, let its own thread act on it), and one
that raises is logged and the publisher goes on.
"""

import asyncio
import copy
import dataclasses
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import replace
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.planner import CancelFlag
from judo.core.planner_view import CycleSize
from judo.runtime.snapshots import LiveFigures, RunSummary, Snapshot, Subscribers, T
from judo.safety.stop import StopLatch

MAX_CYCLE_SECONDS = 10.0
"""Longest estimated planning cycle a config edit may ask for; a bigger one is refused (the plant
would run on an ever older plan, and Pause would be the only way out)."""
LATE_CYCLE = 1.0
"""Seconds after which a cycle in flight is late: the status line counts its time, and an edit that
resizes the cycle cancels it."""
CALIBRATION_STEPS = 20_000
"""Rollout steps a completed cycle needs for its time to re-estimate the cost of one step."""
PROBE_STEPS = 50
"""Physics steps timed on the planning model to estimate one step's cost before any cycle has
run."""
PROBE_REPEATS = 5
"""Runs of PROBE_STEPS timed; the fastest one counts (on a loaded machine one run in a few is not
preempted)."""
RECENT_CYCLES = 9
"""Cycles since the last large one whose median per-step cost makes the estimate."""


def cycle_seconds(step_cost: "StepCost", size: CycleSize, controller: ControllerConfig) -> float:
    """Estimated wall seconds of a cycle of `size` in the app (NaN while the cost is unknown), where
    the optimizer iterations beyond `controller.max_opt_iters` stop at the control period
    (`Controller.update_action`'s deadline): at most the required iterations, or the period and one
    iteration more."""
    full = step_cost.estimate(size)
    required = min(controller.max_opt_iters, size.iterations)
    if required == size.iterations:
        return full
    one = step_cost.estimate(replace(size, iterations=1))
    return min(full, max(required * one, 1.0 / controller.control_freq + one))


class StepCost:
    """Wall seconds one rollout step takes on a session's backend.

    Args:
        model: the planning model, probed for the fastest of PROBE_REPEATS runs of PROBE_STEPS
            physics steps (a few ms) when `probe` is True.
        workers: the rollout threads that share a batch.
        probe: whether to probe now; a GPU backend is not (its time does not scale with the steps),
            and its cost is known only from measured cycles.
    """

    def __init__(self, model: mujoco.MjModel, workers: int, probe: bool = True) -> None:
        self.probed = self.probe(model, workers) if probe else 0.0
        self.seconds = self.probed if probe else math.nan
        # per-step costs since the last large cycle
        self._recent: deque[float] = deque(maxlen=RECENT_CYCLES)

    @staticmethod
    def probe(model: mujoco.MjModel, workers: int) -> float:
        """Seconds per step of `model` from its first keyframe (else its default pose), spread over
        `workers`."""
        data = mujoco.MjData(model)
        if model.nkey:
            mujoco.mj_resetDataKeyframe(model, data, 0)
        per_step = math.inf
        # the fastest run: a run another process preempted says nothing of the steps
        for _ in range(PROBE_REPEATS):
            start = time.perf_counter()
            for _ in range(PROBE_STEPS):
                mujoco.mj_step(model, data)
            per_step = min(per_step, (time.perf_counter() - start) / PROBE_STEPS)
        return per_step / max(1, min(workers, os.cpu_count() or 1))

    def record(self, size: CycleSize, seconds: float) -> None:
        """A cycle of `size` took `seconds`: the new cost of one step. A cycle of fewer than
        CALIBRATION_STEPS steps counts its fixed overhead (a low-level policy's inference, the
        reward) as steps, so it never lowers the cost below the probe's: the estimate errs towards
        refusing, until a large cycle tells."""
        if seconds <= 0 or size.total <= 0:
            return
        per_step = seconds / size.total
        self.seconds = per_step if size.total >= CALIBRATION_STEPS else max(self.probed, per_step)
        # a large cycle measures the steps themselves: it replaces the rest
        if size.total >= CALIBRATION_STEPS:
            self._recent.clear()
        self._recent.append(self.seconds)

    def estimate(self, size: CycleSize) -> float:
        """Estimated wall seconds of a cycle of `size` (NaN while the cost is unknown), from the
        median per-step cost of the recent cycles: one slow cycle (a page loading, a busy core) does
        not refuse the next edit."""
        return size.total * (float(np.median(self._recent)) if self._recent else self.seconds)


class Stopping(Exception):
    """Raised inside the app's coroutines when a stop arrives while they wait for a worker
    thread."""


class StopSignal(threading.Event):
    """The app's stop flag (a threading.Event: `is_set` and `wait` are its own), with asyncio waits
    that a stop cuts short once `bind` has run on the event loop."""

    def __init__(self) -> None:
        super().__init__()
        self._loop: asyncio.AbstractEventLoop | None = None
        # done once a stop is requested, to end waits
        self._stopping: asyncio.Future[None] | None = None

    def bind(self) -> None:
        """Tie the asyncio waits to the running event loop (call it on that loop, before any
        wait)."""
        loop = asyncio.get_running_loop()
        self._stopping, self._loop = loop.create_future(), loop
        if self.is_set():  # the stop came before the loop existed
            self._stopping.set_result(None)

    def unbind(self) -> None:
        """The event loop has ended."""
        self._loop = None

    def set(self) -> None:
        """Stop (from any thread): set the flag and wake every wait."""
        super().set()
        loop = self._loop
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._wake)
            except RuntimeError:  # the loop has already closed
                pass

    def _wake(self) -> None:
        if self._stopping is not None and not self._stopping.done():
            self._stopping.set_result(None)

    async def sleep(self, seconds: float) -> None:
        """Wait `seconds`, or until a stop, whichever comes first."""
        stopping = self._stopping
        if seconds > 0 and stopping is not None and not stopping.done():
            await asyncio.wait((stopping,), timeout=seconds)
        else:
            await asyncio.sleep(0)

    async def in_worker(self, executor: Executor, fn: Callable[..., Any], *args: Any) -> Any:
        """`fn(*args)` run on `executor`'s thread; raises Stopping if a stop comes first (the call
        is abandoned to its thread, which ends after it)."""
        assert self._stopping is not None, "bind() first"
        future = asyncio.get_running_loop().run_in_executor(executor, fn, *args)
        await asyncio.wait((future, self._stopping), return_when=asyncio.FIRST_COMPLETED)
        if self.is_set():
            future.cancel()  # drops the result whenever it comes
            raise Stopping
        return future.result()


class PlanningCycle:
    """One planning cycle in flight: when it started, its size, and its cancel.

    The controller and the rollout pool poll `is_set`, which is also true once the app stops.
    """

    def __init__(self, stop: CancelFlag, size: CycleSize | None, estimate: float) -> None:
        self._stop = stop
        self._cancelled = threading.Event()
        self.size, self.estimate = size, estimate
        self.started = time.perf_counter()
        self.reason: str | None = None  # why it was cancelled

    def is_set(self) -> bool:
        """True once the cycle is cancelled or the app stops."""
        return self._cancelled.is_set() or self._stop.is_set()

    def cancel(self, reason: str) -> None:
        """End the cycle at its next check (`reason` goes on the status line)."""
        if not self._cancelled.is_set():
            self.reason = reason
            self._cancelled.set()

    def elapsed(self) -> float:
        """Wall seconds since the cycle started."""
        return time.perf_counter() - self.started

    def late(self) -> bool:
        """True once the cycle has run longer than LATE_CYCLE."""
        return self.elapsed() > LATE_CYCLE


class CycleInFlight:
    """The planning cycle in flight, or None (`cycle`): the planner runner starts and ends each one
    (`start`), and the app's state cancels it (`AppState.cancel_cycle`, under its lock)."""

    def __init__(self) -> None:
        self.cycle: PlanningCycle | None = None

    def start(self, cycle: PlanningCycle | None) -> None:
        """Make `cycle` the one in flight (None: none is)."""
        self.cycle = cycle


class StateBuffer:
    """Latest snapshot per topic (e.g. "system", "plan"), safe to share between threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._latest: dict[str, Snapshot[Any]] = {}
        self._version = 0
        self._subscribers: dict[str, Subscribers] = {}

    def subscribe(self, topic: str, callback: Callable[[Snapshot[Any]], None]) -> None:
        """Call `callback(snapshot)` with each snapshot of `topic` published from now on, on the
        publisher's thread."""
        with self._lock:
            subscribers = self._subscribers.setdefault(topic, Subscribers())
        subscribers.add(callback)

    def publish(self, topic: str, value: T) -> Snapshot[T]:
        """Store a frozen copy of `value` as the newest snapshot of `topic` and return it.

        The copy is made before taking the lock, so the caller may reuse or change `value` at once.
        """
        frozen = _freeze(copy.deepcopy(value))
        with self._lock:
            self._version += 1
            snapshot = Snapshot(self._version, frozen, time.perf_counter())
            self._latest[topic] = snapshot
            subscribers = self._subscribers.get(topic)
        if subscribers is not None:
            subscribers.fire(snapshot)
        return snapshot

    def latest(self, topic: str) -> Snapshot[Any] | None:
        """The newest snapshot of `topic`, or None if nothing was published to it yet."""
        with self._lock:
            return self._latest.get(topic)

    def clear(self, topic: str) -> None:
        """Forget `topic`, e.g. the old plan after a switch of task."""
        with self._lock:
            self._latest.pop(topic, None)


def _freeze(value: Any) -> Any:
    """Mark every numpy array reachable through dicts, lists, tuples and dataclasses read-only."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, dict):
        for item in value.values():
            _freeze(item)
    elif isinstance(value, (list, tuple)):
        for item in value:
            _freeze(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _freeze(getattr(value, f.name))
    return value


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
