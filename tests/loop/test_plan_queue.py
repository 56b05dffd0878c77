"""PlanQueue: the plans a closed loop made, each waiting for the plant time it takes effect at."""

import numpy as np

from judo.core.spline import Spline, SplineBasis
from judo.loop.timing import PlanQueue


def constant_plan(value: float, start: float = 0.0) -> Spline:
    basis = SplineBasis(np.array([0.0, 1.0]), "linear")
    return Spline(start, basis, np.full((2, 1), value), None, None)


def test_a_plan_takes_effect_at_its_time_and_a_later_one_replaces_those_not_yet_due():
    queue = PlanQueue(stamp=0.0)
    first, second, third = constant_plan(1.0), constant_plan(2.0), constant_plan(3.0)
    queue.schedule(0.1, first, stamp=0.05)
    queue.schedule(0.3, second, stamp=0.2)
    queue.schedule(0.3, third, stamp=0.25)  # due no later than `second`: replaces it
    held = []
    active, stamp, hold = queue.take_due(0.0, lambda: held.append(1) or np.zeros(1))
    assert active is None and stamp == 0.0 and hold is not None and held == [1]
    assert queue.due_at(0.3) is third  # counted as due, but left pending
    assert queue.take_due(0.0, lambda: np.ones(1))[0] is None and held == [1]  # held once
    active, stamp, _ = queue.take_due(0.1, np.zeros)
    assert active is first and stamp == 0.05
    active, stamp, _ = queue.take_due(0.3, np.zeros)
    assert active is third and stamp == 0.25 and queue.due_at(10.0) is third


def test_forget_drops_every_plan_and_the_warm_start_is_made_again():
    queue = PlanQueue(stamp=0.0)
    queue.schedule(0.0, constant_plan(1.0), stamp=0.0)
    assert queue.take_due(0.0, lambda: np.zeros(1))[0] is not None
    queue.forget(stamp=5.0)
    made = []
    active, stamp, hold = queue.take_due(6.0, lambda: made.append(1) or np.full(1, 7.0))
    assert active is None and stamp == 5.0 and made == [1]
    np.testing.assert_array_equal(hold, [7.0])
    assert queue.due_at(6.0) is None
