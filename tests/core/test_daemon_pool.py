"""DaemonThreadPool: results and errors through futures, daemon workers, a bounded shutdown, no
leak."""

import gc
import threading
import time

import pytest

from judo.core.rollouts.rollout import DaemonThreadPool


def alive(name: str) -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith(name)]


def test_results_and_errors_come_back_through_futures():
    pool = DaemonThreadPool(2, "test-pool-a")
    assert pool.submit(pow, 2, 10).result(timeout=5) == 1024
    with pytest.raises(ZeroDivisionError):
        pool.submit(lambda: 1 / 0).result(timeout=5)
    assert all(t.daemon for t in alive("test-pool-a"))
    pool.shutdown()
    assert alive("test-pool-a") == []
    with pytest.raises(RuntimeError, match="after shutdown"):
        pool.submit(pow, 2, 2)


def test_shutdown_waits_at_most_its_timeout_for_a_stuck_call():
    pool = DaemonThreadPool(1, "test-pool-b")
    release = threading.Event()
    stuck = pool.submit(release.wait)
    start = time.perf_counter()
    pool.shutdown(wait=True, timeout=0.2)
    assert time.perf_counter() - start < 1.0 and not stuck.done()
    release.set()
    assert stuck.result(timeout=5) is True  # the abandoned call still finishes in its own time
    time.sleep(0.1)
    assert alive("test-pool-b") == []


def test_threads_start_with_work_and_end_when_the_pool_is_dropped():
    pool = DaemonThreadPool(3, "test-pool-c")
    assert alive("test-pool-c") == []
    for future in [pool.submit(time.sleep, 0.01) for _ in range(3)]:
        future.result(timeout=5)
    assert len(alive("test-pool-c")) == 3
    del pool, future
    gc.collect()
    deadline = time.monotonic() + 5
    while alive("test-pool-c") and time.monotonic() < deadline:
        time.sleep(0.01)
    assert alive("test-pool-c") == []
