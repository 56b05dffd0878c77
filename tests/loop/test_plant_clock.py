"""The plant clock (judo.loop.timing): which steps of a plant are due at a wall time, on given
times (no sleeping), and a wait that ends on a stop."""

import time

import pytest

from judo.loop.timing import MAX_CATCH_UP, PlantClock
from judo.sysid.drive import sleep_until_due

DT = 0.01


def test_step_k_of_a_stretch_is_due_at_origin_plus_k_timesteps():
    clock = PlantClock()
    assert not clock.running and clock.wait(5.0, DT) == 0.0
    assert clock.due(5.0, DT) == 1  # a new stretch: its first step at once
    clock.stepped(1)
    assert clock.due(5.0 + 0.5 * DT, DT) == 0
    assert clock.wait(5.0 + 0.5 * DT, DT) == pytest.approx(0.5 * DT)
    assert clock.due(5.0 + 3.2 * DT, DT) == 3  # steps 1, 2 and 3 came due
    clock.stepped(3)
    assert clock.wait(5.0 + 3.2 * DT, DT) == pytest.approx(0.8 * DT)


def test_a_caller_too_far_behind_falls_behind_instead_of_bursting():
    clock = PlantClock()
    clock.due(0.0, DT)
    clock.stepped(1)
    most = round(MAX_CATCH_UP / DT)
    assert clock.due(10.0, DT) == most  # 10 s late: only MAX_CATCH_UP s of steps at once
    clock.stepped(most)
    assert clock.due(10.0, DT) == 0  # the rest is given up: nothing more is due at that time
    assert clock.wait(10.0, DT) == pytest.approx(DT)


def test_restart_begins_a_new_stretch_at_the_next_due():
    clock = PlantClock()
    clock.due(0.0, DT)
    clock.stepped(1)
    clock.restart()  # e.g. a pause from 0.0 s to 3.0 s
    assert not clock.running and clock.wait(3.0, DT) == 0.0
    assert clock.due(3.0, DT) == 1 and clock.running
    clock.stepped(1)
    assert clock.due(3.0 + 0.9 * DT, DT) == 0  # paced from the new origin, not the old one


def test_sleep_until_due_sleeps_to_the_step_and_ends_on_a_stop():
    clock = PlantClock()
    timestep = 0.05
    start = time.perf_counter()
    assert sleep_until_due(clock, timestep, lambda: False)  # the first step at once
    clock.stepped(1)
    assert sleep_until_due(clock, timestep, lambda: False)
    assert time.perf_counter() - start >= timestep  # never before it is due
    clock.stepped(1)
    assert not sleep_until_due(clock, timestep, lambda: True)
