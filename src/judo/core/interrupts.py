"""Ctrl-C (SIGINT) held off around work that must not be cut in half: a Ray wait, an HDF5 write.

Both helpers act only in the main thread, where Python delivers signals; elsewhere they change nothing.
"""

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def sigint_as_flag() -> Iterator[list[int]]:
    """Within the block a SIGINT is appended to the yielded list instead of raising; the previous handler is
    restored at the end. Outside the main thread the list stays empty and signals are left alone."""
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield caught
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def sigint_deferred() -> Iterator[None]:
    """Hold a Ctrl-C off until the block ends, then raise KeyboardInterrupt (main thread only)."""
    with sigint_as_flag() as caught:
        yield
    if caught:
        raise KeyboardInterrupt
