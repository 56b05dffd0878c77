"""The app's stop: one flag that every thread polls and every asyncio wait is cut short by.

A stop (`App.stop()`, Ctrl-C, SIGTERM, the duration reached, a dead plant thread) calls `set` from any thread.
Threads see it with `is_set` / `wait`; the event loop's coroutines sleep with `sleep` and run blocking calls with
`in_worker`, both of which return, or raise `Stopping`, as soon as it is set.
"""

import asyncio
import threading
from collections.abc import Callable
from concurrent.futures import Executor
from typing import Any


class Stopping(Exception):
    """Raised inside the app's coroutines when a stop arrives while they wait for a worker thread."""


class StopSignal:
    """The app's stop flag, with asyncio waits that a stop cuts short once `bind` has run on the event loop."""

    def __init__(self) -> None:
        self._flag = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Future[None] | None = None  # done once a stop is requested, to end waits

    def bind(self) -> None:
        """Tie the asyncio waits to the running event loop (call it on that loop, before any wait)."""
        loop = asyncio.get_running_loop()
        self._stopping, self._loop = loop.create_future(), loop
        if self._flag.is_set():  # the stop came before the loop existed
            self._stopping.set_result(None)

    def unbind(self) -> None:
        """The event loop has ended."""
        self._loop = None

    def set(self) -> None:
        """Stop (from any thread): set the flag and wake every wait."""
        self._flag.set()
        loop = self._loop
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._wake)
            except RuntimeError:  # the loop has already closed
                pass

    def _wake(self) -> None:
        if self._stopping is not None and not self._stopping.done():
            self._stopping.set_result(None)

    def is_set(self) -> bool:
        return self._flag.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block this thread for at most `timeout` s, until a stop; True if stopped."""
        return self._flag.wait(timeout)

    async def sleep(self, seconds: float) -> None:
        """Wait `seconds`, or until a stop, whichever comes first."""
        stopping = self._stopping
        if seconds > 0 and stopping is not None and not stopping.done():
            await asyncio.wait((stopping,), timeout=seconds)
        else:
            await asyncio.sleep(0)

    async def in_worker(self, executor: Executor, fn: Callable[..., Any], *args: Any) -> Any:
        """`fn(*args)` run on `executor`'s thread; raises Stopping if a stop comes first (the call is abandoned
        to its thread, which ends after it)."""
        assert self._stopping is not None, "bind() first"
        future = asyncio.get_running_loop().run_in_executor(executor, fn, *args)
        await asyncio.wait((future, self._stopping), return_when=asyncio.FIRST_COMPLETED)
        if self._flag.is_set():
            future.cancel()  # drops the result whenever it comes
            raise Stopping
        return future.result()
