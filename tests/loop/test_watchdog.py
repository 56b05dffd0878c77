"""The watchdog's verdicts and what it tells: readings that stop are named as such, every few
seconds, until they resume; the end of each trouble told is told with how long it took; a trouble
that comes back at once is counted rather than told again; a newer plan due sooner replaces a
pending one (no backlog while the readings stand still)."""

import numpy as np
import pytest
from slider_task import hold_base

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.controller import Controller
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.loop.timing import REPORT_EVERY, Watchdog
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

CONTROL_FREQ, MAX_PLAN_AGE = 20.0, 0.2
LIMIT = MAX_PLAN_AGE + 1.0 / CONTROL_FREQ
"""Seconds of plan age beyond which the safe action is served."""


@pytest.fixture
def controller(tmp_path):
    """A tiny planner for the block on a rail, planning from the reading predicted to when its plan
    takes effect."""

    class Hold(hold_base(tmp_path)):
        def reset(self):
            self.data.qpos[:] = 0.3
            self.data.qvel[:] = 0.0

    config = ControllerConfig(
        horizon=0.1, control_freq=CONTROL_FREQ, max_plan_age=MAX_PLAN_AGE, latency_compensation=True
    )
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=4, num_nodes=2, sigma=0.3), nu=1
    )
    optimizer.rng = np.random.default_rng(0)
    with Controller(config, Hold(), optimizer, num_workers=1) as controller:
        yield controller


def run_as_the_app(loop: ClosedLoop, seconds: float) -> None:
    """Step the plant for `seconds` of plant time, planning every control period from the latest
    reading whether or not its time advanced, as the app's planner does on the wall clock (the
    loop's clock here is plant time)."""
    every = round(1.0 / (CONTROL_FREQ * loop.system.timestep))
    for i in range(round(seconds / loop.system.timestep)):
        if i % every == 0:
            loop.plan(loop.reading)
        loop.advance()


def test_readings_that_stop_are_named_every_few_seconds_until_they_resume_and_the_end_says_how_long(
    controller,
):
    events: list[str | None] = []
    plant = MujocoSystem.from_task(controller.task, seed=0)
    loop = ClosedLoop(controller, plant, latency=0.02, on_watchdog=events.append)
    loop.restart()
    run_as_the_app(loop, 0.5)
    assert events == [] and loop.watchdog.trips == 0  # fresh plans while the readings flow
    read = plant.read_state
    frozen = read()
    # the robot's process dies: its last reading stays the reading
    plant.read_state = lambda: frozen
    run_as_the_app(loop, 2 * REPORT_EVERY + 1.0)
    told = [event for event in events if event is not None]
    assert len(told) == 3 and None not in events  # at the trip, then every REPORT_EVERY s
    assert all(
        event.startswith("the readings stopped: their time has not advanced for ") for event in told
    )
    stood = [float(event.split("advanced for ")[1].split(" s")[0]) for event in told]
    # named at the trip, not blamed on planning: the plan's age is past LIMIT, less than a period of
    # it planning's
    assert LIMIT - 1.0 / CONTROL_FREQ - 0.03 < stood[0] <= LIMIT
    assert stood[1] == pytest.approx(stood[0] + REPORT_EVERY, abs=0.035)
    assert stood[2] == pytest.approx(stood[0] + 2 * REPORT_EVERY, abs=0.035)
    assert loop.serve(loop.reading.time) == pytest.approx(loop.safe_action())
    assert (
        len(loop.plans._pending) <= 1
    )  # the plans made from the same reading replaced one another
    plant.read_state = read  # the robot is back
    run_as_the_app(loop, 0.5)
    assert events[-1] is None and events.count(None) == 1 and loop.watchdog.tripped is None
    resumed = loop.watchdog.resumed_s  # fresh plans a cycle or two after the readings resumed
    assert resumed is not None and 0 < resumed <= 3 / CONTROL_FREQ
    assert loop.watchdog.episode_s == pytest.approx(
        2 * REPORT_EVERY + 1.0 - stood[0] + resumed, abs=0.035
    )


def test_a_stalled_planner_is_still_blamed_on_planning_while_the_readings_flow(controller):
    events: list[str | None] = []
    loop = ClosedLoop(
        controller, MujocoSystem.from_task(controller.task, seed=0), on_watchdog=events.append
    )
    loop.restart()
    run_as_the_app(loop, 0.3)
    # no plan: the planner hangs
    for _ in range(round((REPORT_EVERY + 0.5) / loop.system.timestep)):
        loop.advance()
    # at the trip, then REPORT_EVERY s on
    assert len(events) == 2 and all(event is not None for event in events)
    assert all(
        event.startswith("the plan in force is ")
        and event.endswith(" s old (planning stalled or failed)")
        for event in events
    )
    ages = [float(event.split("is ")[1].split(" s")[0]) for event in events]
    assert LIMIT - 0.006 < ages[0] <= LIMIT + 0.016 and ages[1] == pytest.approx(
        ages[0] + REPORT_EVERY, abs=0.035
    )
    run_as_the_app(loop, 0.2)
    assert events[-1] is None and loop.watchdog.resumed_s is None  # the readings never stopped


def test_a_trouble_that_comes_back_at_once_is_counted_not_told_and_its_end_is_told_only_if_its_start_was():  # noqa: E501
    watchdog, period = Watchdog(), 1.0 / CONTROL_FREQ
    watchdog.restart(0.0)
    told = []

    # readings at every call; the plan in force is stamped `stamp`
    def serve(now: float, stamp: float) -> None:
        watchdog.fresh_at = now
        reason = watchdog.verdict(now, stamp, MAX_PLAN_AGE, CONTROL_FREQ)
        if watchdog.news:
            told.append((now, reason))

    serve(1.0, 0.5)  # a slow planner: too old
    serve(1.1, 1.0)  # fresh again: the end is told
    serve(2.0, 1.5)  # too old again 0.9 s after the last line: counted
    serve(2.1, 2.0)  # its end is not told
    serve(3.0, 2.5)  # and again
    serve(3.1, 3.0)
    assert [(now, reason is None) for now, reason in told] == [(1.0, False), (1.1, True)]
    assert watchdog.trips == 3
    serve(4.0, 3.5)  # within REPORT_EVERY of the last line: counted, but it lasts
    # ... until REPORT_EVERY after the last line: told, with the count
    serve(1.0 + REPORT_EVERY, 3.5)
    assert told[-1][0] == 1.0 + REPORT_EVERY
    assert (
        told[-1][1]
        == "the plan in force is 2.50 s old (planning stalled or failed) (2 shorter episodes "
        "since the last report)"
    )
    serve(6.1, 6.0)
    assert told[-1] == (6.1, None) and watchdog.episode_s == pytest.approx(6.1 - 4.0)
    assert MAX_PLAN_AGE + period < 0.5  # the ages above are all beyond the limit


def test_a_newer_plan_due_no_later_than_a_pending_one_replaces_it(controller):
    loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0), latency=0.2)
    reading = loop.restart()
    slow = loop.plan(reading)
    loop.latency = 0.1
    fast = loop.plan(reading)
    assert slow is not None and fast is not None
    served = loop.serve(reading.time + 0.1)  # the newer plan, due at 0.1 s, is served at once
    assert served == pytest.approx(fast(reading.time + 0.1, reading.state))
    assert loop.serve(reading.time + 0.2) == pytest.approx(fast(reading.time + 0.2, reading.state))
