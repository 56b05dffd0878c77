"""Ctrl-C while a Ray loop waits: `cluster.wait_any` answers it within a wait slice, and cancelling
leaves the workers alive (no force-kill racing the tasks' replies)."""

import os
import signal
import threading
import time

import pytest

import judo.ray_cluster as cluster


def test_ctrl_c_during_a_wait_raises_within_a_slice_and_the_tasks_cancel(local_ray):
    ray = pytest.importorskip("ray")

    # local, so Ray ships it by value (workers cannot import this module)
    def busy(seconds: float) -> float:
        # Python code running, as an episode's loop is (a non-forced cancel
        end = time.monotonic() + seconds
        # lands between bytecodes; Ray does not interrupt a time.sleep)
        while time.monotonic() < end:
            pass
        return seconds

    remote = ray.remote(num_cpus=1)(busy)
    refs = [remote.remote(60.0)]
    assert cluster.wait_any([remote.remote(0.0)])[0]  # a finished task returns at once
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        cluster.wait_any(refs)
    # Within a slice of the Ctrl-C, not when the 60 s task ends: 1 s + WAIT_SLICE_S on an idle
    # machine, and a loaded one may start the timer's thread and Ray's wait late, so the bound is
    # generous.
    answered_after = time.monotonic() - started
    assert answered_after < 20.0, f"the Ctrl-C was answered after {answered_after:.1f} s"
    # the flag handler is gone again
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    cluster.cancel(refs)
    with pytest.raises(ray.exceptions.TaskCancelledError):
        # cancelled: never the task's 60.0, however late the cancel lands
        ray.get(refs[0], timeout=120)
