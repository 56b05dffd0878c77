"""Ctrl-C (SIGINT) held off around work that must not be cut in half: a Ray wait, an HDF5 write.

Both helpers act only in the main thread, where Python delivers signals; elsewhere they change
nothing.
"""

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def sigint_as_flag(signals: tuple[int, ...] = (signal.SIGINT,)) -> Iterator[list[int]]:
    """Within the block each of `signals` (SIGINT; add SIGTERM for a stop request) is appended to
    the yielded list instead of raising; the previous handlers are restored at the end. Outside the
    main thread the list stays empty and signals are left alone."""
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return
    previous = {
        signum: signal.signal(signum, lambda signum, frame: caught.append(signum))
        for signum in signals
    }
    try:
        yield caught
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextmanager
def sigint_deferred() -> Iterator[None]:
    """Hold a Ctrl-C off until the block ends, then raise KeyboardInterrupt (main thread only)."""
    with sigint_as_flag() as caught:
        yield
    if caught:
        raise KeyboardInterrupt
