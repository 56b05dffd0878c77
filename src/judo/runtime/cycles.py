"""The app's planning cycle: its size (N x R x iterations x T steps), its estimated wall time, the
cycle in flight with its cancel, and the app's stop that cancels it too.

A cycle's cost is its rollout steps (`CycleSize`, the planner's `cycle_size`: num_rollouts x
num_randomizations x iterations x T), times the seconds one step takes on the session's rollout
backend (`StepCost`): probed on the planning model when the session is built, then measured from
each completed cycle large enough for its fixed overhead not to count. The commands refuse an edit
whose estimated cycle exceeds MAX_CYCLE_SECONDS (`judo.runtime.commands`), and the GUI shows the
cost.

The planner runner plans under a `PlanningCycle`: the controller polls it (`is_set`) between
optimizer iterations and the CPU rollout pool between pieces of a batch, so a pause, reset, switch
or resize that cancels it ends it within a fraction of a second, keeping the plan before.

`StopSignal` is the app's stop (`AppState.stop`): one flag that every thread polls and every asyncio
wait is cut short by. A stop (`App.stop()`, Ctrl-C, SIGTERM, the duration reached, a dead plant
thread) calls `set` from any thread. Threads see it with `is_set` / `wait` (a threading.Event's
own); the event loop's coroutines sleep with `sleep` and run blocking calls with `in_worker`, both
of which return, or raise `Stopping`, as soon as it is set.
"""

import asyncio
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.planner import CancelFlag
from judo.core.planner_view import CycleSize

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


@dataclass(frozen=True)
class CycleCost:
    """What the GUI shows of the cycle: the configs' size and estimated seconds, the last completed
    cycle's seconds, and how long the cycle in flight has run when it is late (else None)."""

    size: CycleSize | None
    estimate: float
    last: float
    running_for: float | None

    def line(self) -> str:
        """The cost as one line: 'cycle 64 x 1 x 1 x 100 = 6,400 steps, est. 12 ms; last plan 9.8
        ms'."""
        if self.size is None:
            return f"last update {seconds_text(self.last)}"
        estimated = f", est. {seconds_text(self.estimate)}" if math.isfinite(self.estimate) else ""
        text = f"cycle {self.size}{estimated}; last plan {seconds_text(self.last)}"
        if self.running_for is not None:
            text += f"; planning: {self.running_for:.0f} s so far"
        return text


def seconds_text(seconds: float) -> str:
    """'9.8 ms', '1.2 s', '-' for NaN."""
    if not math.isfinite(seconds):
        return "-"
    return f"{1e3 * seconds:.1f} ms" if seconds < 1 else f"{seconds:.1f} s"
