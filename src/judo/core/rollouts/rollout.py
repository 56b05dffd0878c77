"""`RolloutPool`, the CPU rollout backend: one shared MjModel, one MjData per worker thread, one C
call per chunk.

It implements `judo.core.rollouts.backend.RolloutBackend`, as the MuJoCo Warp backend
(core/rollouts/warp_rollout.py) does; the factory `make_rollout_backend` lives in
core/rollouts/factory.py.

`DaemonThreadPool`, the pool its workers run on (the reward's threads, the feedback gains' and the
app's planning thread use it too): a thread pool whose workers never keep the process alive.

`concurrent.futures.ThreadPoolExecutor` joins its threads when the interpreter exits, so a worker
stuck in one long call (a batch of 10**5 rollouts, a user reward that sleeps) holds up Ctrl-C until
the call returns. `DaemonThreadPool` runs the same work on daemon threads and its `shutdown` can
stop waiting after a timeout: an abandoned call finishes on its own, or ends with the process.
"""

import os
import queue
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from typing import Any

import mujoco
import mujoco.rollout
import numpy as np

from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import (
    PlanningCancelled,
    RolloutBackend,
    check_blocks,
    check_model_sizes,
)

__all__ = ["CLOSE_TIMEOUT", "MOCAP_CONTROL_SPEC", "DaemonThreadPool", "RolloutPool"]

# of (future, fn, args, kwargs), or None: the signal for one worker to end
WorkQueue = queue.SimpleQueue


class DaemonThreadPool(Executor):
    """Up to `num_workers` daemon threads named `name_0`, `name_1`, ... running submitted calls in
    order.

    The threads start with the first calls; they end on `shutdown()`, or when the pool is garbage
    collected (the workers hold no reference to it)."""

    def __init__(self, num_workers: int, name: str) -> None:
        self.num_workers, self.name = max(1, num_workers), name
        self._queue: WorkQueue = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._shutdown = False
        self._threads: list[threading.Thread] = []
        self._finalizer = weakref.finalize(self, _end_workers, self._queue, self._threads)

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        """Queue `fn(*args, **kwargs)`; its Future holds the result or the exception it raised."""
        future: Future = Future()
        with self._lock:
            if self._shutdown:
                raise RuntimeError("cannot schedule new work after shutdown")
            self._queue.put((future, fn, args, kwargs))
            if len(self._threads) < self.num_workers:
                thread = threading.Thread(
                    target=_work,
                    args=(self._queue,),
                    name=f"{self.name}_{len(self._threads)}",
                    daemon=True,
                )
                thread.start()
                self._threads.append(thread)
        return future

    def shutdown(
        self, wait: bool = True, *, cancel_futures: bool = False, timeout: float | None = None
    ) -> None:
        """Let the workers end after the call they are running; wait for them (at most `timeout`
        s)."""
        with self._lock:
            if not self._shutdown:
                self._shutdown = True
                if cancel_futures:
                    while True:
                        try:
                            item = self._queue.get_nowait()
                        except queue.Empty:
                            break
                        if item is not None:
                            item[0].cancel()
                self._finalizer()
        if wait:
            deadline = None if timeout is None else time.monotonic() + timeout
            for thread in self._threads:
                if thread is not threading.current_thread():
                    thread.join(None if deadline is None else max(0.0, deadline - time.monotonic()))


def _end_workers(work: WorkQueue, threads: list[threading.Thread]) -> None:
    for _ in threads:
        work.put(None)


def _work(work: WorkQueue) -> None:
    while (item := work.get()) is not None:
        _run(*item)
        del item  # hold no reference to finished work while idle


def _run(future: Future, fn: Callable[..., Any], args: tuple, kwargs: dict) -> None:
    if not future.set_running_or_notify_cancel():
        return
    try:
        result = fn(*args, **kwargs)
    except BaseException as err:  # handed to whoever waits on the future
        future.set_exception(err)
    else:
        future.set_result(result)


MOCAP_CONTROL_SPEC = (
    mujoco.mjtState.mjSTATE_CTRL
    | mujoco.mjtState.mjSTATE_MOCAP_POS
    | mujoco.mjtState.mjSTATE_MOCAP_QUAT
)
"""Per-step inputs of a rollout on a model with mocap bodies: [ctrl, mocap_pos, mocap_quat].
MuJoCo's rollout resets mocap poses to the model's defaults unless they are passed as inputs like
this."""


CLOSE_TIMEOUT = 0.5
"""Most seconds `RolloutPool.close` waits for its workers."""
PIECE_STEPS = 50_000
"""Most rollout steps one C call of a worker takes while a `cancel` flag is set on the pool: a
bigger chunk is rolled out in pieces of whole rows, the flag polled between them, so a cancelled
batch ends within a piece."""


class RolloutPool(RolloutBackend):
    """Rolls out batches of control sequences from one initial state on `num_workers` threads.

    The batch is split into one contiguous chunk per worker; each worker runs MuJoCo's C rollout on
    its own MjData with the GIL released. Output buffers, and each chunk's list of per-rollout
    models, are built when the batch shape or the models change and reused otherwise, so the
    returned arrays are overwritten by the next call. Under `set_models` MuJoCo's rollout gets the
    mixed list of models, by reference: nothing is copied per call.
    """

    name = "cpu"

    def __init__(self, model: mujoco.MjModel, num_workers: int | None = None) -> None:
        self.model = model
        self.num_workers = max(1, num_workers or os.cpu_count() or 1)
        self.nstate = mujoco.mj_stateSize(model, STATE_SPEC)
        self._datas = [mujoco.MjData(model) for _ in range(self.num_workers)]
        self._runners = [mujoco.rollout.Rollout(nthread=0) for _ in range(self.num_workers)]
        self._executor = DaemonThreadPool(self.num_workers, "judo-rollout")
        self._shape: tuple[int, int] | None = None
        self._models: list[mujoco.MjModel] = [model]
        self._splits: dict[int, tuple[list[slice], list[list[mujoco.MjModel]]]] = {}

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """See `RolloutBackend.set_models`; raises RandomizedRolloutError for a model of other
        sizes."""
        models = [self.model] if models is None else check_model_sizes(self.model, models)
        self._models = models
        self._splits.clear()  # rebuild the chunks' model lists on the next rollout

    def _allocate(self, num_rollouts: int, num_steps: int) -> None:
        self._shape = (num_rollouts, num_steps)
        self._initial = np.zeros((num_rollouts, self.nstate))
        self._states = np.zeros((num_rollouts, num_steps, self.nstate))
        self._sensors = np.zeros((num_rollouts, num_steps, self.model.nsensordata))
        self._inputs = np.zeros((num_rollouts, num_steps, self.model.nu + 7 * self.model.nmocap))

    def _split(self, num_rollouts: int) -> tuple[list[slice], list[list[mujoco.MjModel]]]:
        """The rows of each worker's contiguous chunk and each chunk's per-row models, kept per
        batch size until `set_models` changes the models."""
        # checked once per batch size and models, as the split is made
        if num_rollouts not in self._splits:
            check_blocks(num_rollouts, len(self._models))
            bounds = np.linspace(0, num_rollouts, min(self.num_workers, num_rollouts) + 1).astype(
                int
            )
            chunks = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
            block = num_rollouts // len(self._models)
            # block r: models[r]
            row_models = [model for model in self._models for _ in range(block)]
            self._splits[num_rollouts] = (chunks, [row_models[c] for c in chunks])
        return self._splits[num_rollouts]

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """See `RolloutBackend.rollout`; the work is split into one contiguous chunk per worker
        thread."""
        num_rollouts, num_steps, _ = controls.shape
        self._split(num_rollouts)  # RandomizedRolloutError before anything is written
        if self._shape != (num_rollouts, num_steps):
            self._allocate(num_rollouts, num_steps)
        self._initial[:] = initial_state
        spec = mujoco.mjtState.mjSTATE_CTRL
        if mocap is not None and self.model.nmocap:
            self._inputs[..., : self.model.nu] = controls
            self._inputs[..., self.model.nu :] = mocap
            controls, spec = self._inputs, MOCAP_CONTROL_SPEC
        self.rollout_rows(
            self._initial, controls, spec, self._states, self._sensors, caller_runs_first=False
        )
        return self._states, self._sensors

    def blocks(self, num_rollouts: int) -> list[slice]:
        """The contiguous block of rows each worker rolls out of a batch of `num_rollouts`: one
        block per worker, or one per row when there are fewer rows than workers."""
        return self._split(num_rollouts)[0]

    def for_each_block(
        self, num_rollouts: int, work: Callable[[int], None], caller_runs_first: bool = True
    ) -> None:
        """Call `work(block)` once for each block of a batch of `num_rollouts` (see `blocks`), on
        the worker threads, and return once every call has returned; the first error is re-raised
        after all have ended.

        With `caller_runs_first` the calling thread runs block 0 itself rather than wait, one thread
        hand-off fewer; `rollout` (one long call) leaves all blocks to the daemon workers, so that a
        caller waiting on them stays interruptible.
        """
        count = len(self.blocks(num_rollouts))
        if count == 1:
            work(0)
            return
        first = 1 if caller_runs_first else 0
        futures = [self._executor.submit(work, block) for block in range(first, count)]
        try:
            if caller_runs_first:
                work(0)
        finally:
            for future in futures:
                future.exception()  # every block has ended before any error propagates
        for future in futures:
            future.result()

    def rollout_block(
        self,
        block: int,
        initial_states: np.ndarray,
        inputs: np.ndarray,
        control_spec: int,
        states: np.ndarray,
        sensors: np.ndarray,
    ) -> None:
        """Roll the rows of block `block` (see `blocks`) out on that block's MjData, on the calling
        thread.

        The arrays hold the whole batch, of which only the block's rows are read and written; all
        are C-contiguous float64: initial_states (N, nstate); inputs (N, k, ncontrol), the per-step
        values of `control_spec` ([ctrl] or [ctrl, mocap_pos, mocap_quat]); states (N, k, nstate)
        and sensors (N, k, nsensordata). A low-level policy's worker
        (core/rollouts/low_level_rollout.py) calls it once per tick.
        """
        chunks, chunk_models = self._split(len(initial_states))
        self._run_chunk(
            block, chunks, chunk_models, initial_states, inputs, control_spec, states, sensors
        )

    def rollout_rows(
        self,
        initial_states: np.ndarray,
        inputs: np.ndarray,
        control_spec: int,
        states: np.ndarray,
        sensors: np.ndarray,
        caller_runs_first: bool = True,
    ) -> None:
        """Roll row i of `inputs` out from row i of `initial_states`, into the caller's output
        arrays: every block on its worker (arrays as in `rollout_block`; `caller_runs_first` as in
        `for_each_block`)."""

        def roll(block: int) -> None:
            self.rollout_block(block, initial_states, inputs, control_spec, states, sensors)

        self.for_each_block(len(initial_states), roll, caller_runs_first)

    def _run_chunk(
        self,
        worker: int,
        chunks: list[slice],
        chunk_models: list[list[mujoco.MjModel]],
        initial_states: np.ndarray,
        controls: np.ndarray,
        control_spec: int,
        states: np.ndarray,
        sensors: np.ndarray,
    ) -> None:
        chunk, models, cancel = chunks[worker], chunk_models[worker], self.cancel
        num_steps = controls.shape[1]
        rows = chunk.stop - chunk.start
        piece = rows if cancel is None else max(1, PIECE_STEPS // max(1, num_steps))
        # one call unless a cancellable chunk is bigger than PIECE_STEPS
        for first in range(0, rows, piece):
            if cancel is not None and cancel.is_set():
                raise PlanningCancelled(
                    "planning cycle cancelled part-way through a batch of rollouts; the "
                    "previous plan stays in force"
                )
            part = slice(chunk.start + first, min(chunk.stop, chunk.start + first + piece))
            self._runners[worker].rollout(
                models if piece >= rows else models[first : first + piece],
                [self._datas[worker]],
                initial_states[part],
                controls[part],
                control_spec=control_spec,
                skip_checks=True,
                nstep=num_steps,
                state=states[part],
                sensordata=sensors[part],
            )

    def close(self) -> None:
        """Stop the worker threads; the pool cannot be used afterwards.

        Waits at most CLOSE_TIMEOUT seconds: a worker still inside a long rollout ends when it
        returns (the workers are daemon threads, so it never holds up the process's exit)."""
        self._executor.shutdown(wait=True, timeout=CLOSE_TIMEOUT)
