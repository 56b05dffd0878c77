"""A thread pool whose workers never keep the process alive.

`concurrent.futures.ThreadPoolExecutor` joins its threads when the interpreter exits, so a worker
stuck in one long call (a batch of 10**5 rollouts, a user reward that sleeps) holds up Ctrl-C until
the call returns. `DaemonThreadPool` runs the same work on daemon threads and its `shutdown` can
stop waiting after a timeout: an abandoned call finishes on its own, or ends with the process.
"""

import queue
import threading
import time
import weakref
from collections.abc import Callable
from concurrent.futures import Executor, Future
from typing import Any

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
