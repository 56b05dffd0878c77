"""The shared Ctrl-C helpers: a SIGINT inside the block is held, then reported (flag) or raised
(deferred)."""

import os
import signal
import threading

import pytest

from judo.core.commandline.interrupts import sigint_as_flag, sigint_deferred


def test_a_sigint_inside_the_flag_block_is_recorded_and_the_handler_restored() -> None:
    before = signal.getsignal(signal.SIGINT)
    with sigint_as_flag() as caught:
        os.kill(os.getpid(), signal.SIGINT)
        finished = True  # the signal did not cut the block short
    assert finished and caught == [signal.SIGINT]
    assert signal.getsignal(signal.SIGINT) is before


def test_a_deferred_sigint_raises_only_after_the_whole_block_ran() -> None:
    steps = []
    with pytest.raises(KeyboardInterrupt):
        with sigint_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            steps.append("after the signal")
    assert steps == ["after the signal"]


def test_a_block_without_a_sigint_raises_nothing() -> None:
    with sigint_deferred():
        value = 1
    assert value == 1


def test_outside_the_main_thread_signals_are_left_alone() -> None:
    seen: list[object] = []

    def worker() -> None:
        with sigint_as_flag() as caught:
            seen.append(caught)
            seen.append(signal.getsignal(signal.SIGINT))

    before = signal.getsignal(signal.SIGINT)
    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen == [[], before]
