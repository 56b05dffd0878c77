"""The app's estimator on a thread of its own: a slow filter neither slows the plant nor stops the
estimates the planner plans from; a reset restarts it, its failure is reported, a stop ends it;
config edits are handed over. Real physics (cartpole, 10 ms steps, sensors at 100 Hz, 10 ms late)
and a real EKF, slowed by a sleep in its update. The plant is the simulator behind a user's System,
which the app steps at wall-clock pace whatever the planner does (judo's own simulator would wait
for a planner starved on a loaded machine)."""

import threading
import time

import numpy as np
import pytest

from judo.estimators.ekf import ExtendedKalmanFilter
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem
from judo.runtime.app import App
from judo.runtime.gui.plots import estimation_error
from judo.runtime.running.estimator_thread import CATCH_UP_LAG, EstimatorThread
from judo.tasks.cartpole import Cartpole

SENSING = {"noise": 0.005, "delay": 0.01, "rate": 100.0}
SLOW_UPDATE = 0.1
"""Seconds each filter update sleeps: ten plant steps, so a filter on the plant thread would hold
the simulation to a real-time factor of at most STEP / SLOW_UPDATE = 0.1."""
STEP = 0.01
"""Cartpole's timestep (s)."""


def slowed_app(
    sleep: float = SLOW_UPDATE, per_sim_second: float = 0.0
) -> tuple[App, EstimatorThread, dict]:
    """A cartpole app observing sensors through an EKF whose update sleeps `sleep` s, plus
    `per_sim_second` s for each second of plant time it steps the filter on, and the filter's
    switches: "fail" (raise in update while true), "updates" and "resets" (counts)."""
    plant = SensedSystem(
        MujocoSystem.from_task(Cartpole(), seed=0), **SENSING, rng=np.random.default_rng(0)
    )
    # never waits for the planner
    app = App("cartpole", "mppi", gui=False, seed=0, num_workers=1, system=plant)
    threaded = app.session.closed_loop.estimator
    assert isinstance(threaded, EstimatorThread) and isinstance(
        threaded.estimator, ExtendedKalmanFilter
    )
    inner = threaded.estimator
    update, reset = inner.update, inner.reset
    switches: dict[str, object] = {"fail": False, "updates": 0, "resets": 0}
    reached = [0.0]  # the plant time the filter has stepped to

    def slow_update(reading, now, controls):
        time.sleep(sleep + per_sim_second * max(0.0, now - reached[0]))
        reached[0] = max(reached[0], now)
        if switches["fail"]:
            raise RuntimeError("the filter broke")
        switches["updates"] = int(switches["updates"]) + 1  # type: ignore[call-overload]
        return update(reading, now, controls)

    def counted_reset(reading):
        switches["resets"] = int(switches["resets"]) + 1  # type: ignore[call-overload]
        reached[0] = reading.time
        return reset(reading)

    inner.update, inner.reset = slow_update, counted_reset  # type: ignore[method-assign]
    return app, threaded, switches


def real_time_factor(app: App, seconds: float) -> float:
    sim0, wall0 = app.stats.sim_time(), time.perf_counter()
    time.sleep(seconds)
    return (app.stats.sim_time() - sim0) / (time.perf_counter() - wall0)


def test_a_slow_filter_neither_slows_the_plant_nor_stops_the_estimates_it_plans_from(wait_until):
    app, threaded, switches = slowed_app()
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 3, timeout=30, what="plans")
        fused, plans = threaded.fused, app.stats.num_plans()
        first = app.buffer.latest("plan").value.time
        rtf = real_time_factor(app, 2.0)
        # 3 x what the filter would allow on the plant thread; 1 on an idle machine
        assert rtf > 3 * STEP / SLOW_UPDATE, (
            f"the plant ran at {rtf:.2f} x real time behind a slow filter"
        )
        # The filter fuses at its own rate (a newer reading overtakes the ones it had no time
        # for) ...
        assert 5 <= threaded.fused - fused <= 2.0 / SLOW_UPDATE + 2
        assert threaded.passed_over > 0 and int(switches["updates"]) >= threaded.fused - 1  # type: ignore[call-overload]
        assert 0 < threaded.lag < 1.0  # its newest estimate is a few steps behind the plant's now
        # ... and the planner plans from estimates at the plant's now that follow the plant.
        assert (
            app.stats.num_plans() >= plans + 3
            and app.buffer.latest("plan").value.time > first + 0.3
        )
        snapshot = app.buffer.latest("system").value
        assert abs(snapshot.reading.time - app.session.system.time) < 0.05
        position, velocity = estimation_error(
            app.session.controller.task.model, snapshot.true_state, snapshot.reading.state
        )
        assert position < 0.1 and velocity < 1.0
    finally:
        app.stop()


def test_a_filter_slower_than_the_plant_starts_over_and_its_lag_stays_bounded(wait_until):
    # each second of plant time costs it two
    app, threaded, _ = slowed_app(sleep=0.0, per_sim_second=2.0)
    app.start()
    try:
        wait_until(lambda: threaded.catch_ups >= 1, timeout=30, what="the filter to start over")
        lags, errors = [], []
        model = app.session.controller.task.model
        # 2 s: left alone, the lag would triple at every update (0.5, 1.5, 4.5 s, ...)
        for _ in range(40):
            time.sleep(0.05)
            lags.append(threaded.lag)
            snapshot = app.buffer.latest("system").value
            errors.append(estimation_error(model, snapshot.true_state, snapshot.reading.state)[0])
        # at most CATCH_UP_LAG plus one update, which takes twice the lag it starts from: 3 x
        # CATCH_UP_LAG
        assert max(lags) < 4 * CATCH_UP_LAG and threaded.catch_ups >= 2
        # started over from the prediction, corrected by the newest reading: within 0.25 most of the
        # time. The error grows with the lag, which wall-clock load sets: medians of 0.03-0.12 in
        # clean CI runs (0.124 in session 14's), one snapshot at a start-over 0.6 (CI run 4). The
        # lag bound above is what catches a filter left to fall behind; this one catches a
        # start-over from a wrong state.
        assert np.median(errors) < 0.25, errors
    finally:
        app.stop()


def test_a_reset_restarts_the_filter_from_the_plants_start(wait_until):
    app, threaded, switches = slowed_app()
    app.start()
    try:
        wait_until(lambda: app.stats.sim_time() > 1.0, timeout=30, what="a second of sim time")
        resets, done = int(switches["resets"]), app.resets_done  # type: ignore[call-overload]
        assert threaded.estimator.start_time < 0.05  # the filter's timeline began with the plant
        requested = app.session.system.time  # cartpole's reset keeps the plant's clock going
        app.commands.reset_task()
        wait_until(lambda: app.resets_done == done + 1, what="the plant's reset")
        # begun afresh
        assert switches["resets"] == resets + 1 and threaded.estimator.start_time >= requested
        fused = threaded.fused
        wait_until(lambda: threaded.fused >= fused + 3, what="the filter to fuse after the reset")
        snapshot = app.buffer.latest("system").value
        # the estimate at the plant's now
        assert abs(snapshot.reading.time - app.session.system.time) < 0.05
        position, _ = estimation_error(
            app.session.controller.task.model, snapshot.true_state, snapshot.reading.state
        )
        assert position < 0.1
        assert app.status.level == "info"
    finally:
        app.stop()


def test_a_failing_filter_is_reported_and_the_app_goes_on(wait_until):
    app, threaded, switches = slowed_app(sleep=0.005)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 3, timeout=30, what="plans")
        switches["fail"] = True
        wait_until(
            lambda: "the filter broke" in app.status.message, what="the failure on the status line"
        )
        assert (
            app.status.level == "error"
            and "failed on its thread: RuntimeError" in app.status.message
        )
        sim = app.stats.sim_time()
        wait_until(lambda: app.stats.sim_time() > sim + 0.3, what="the plant to go on stepping")
        assert app.running and threaded.failures > 0
        switches["fail"] = False
        wait_until(lambda: app.status.level == "info", what="the recovery on the status line")
        assert app.status.message.startswith("the system steps again")
    finally:
        app.stop()


def test_a_stop_ends_a_slow_filters_thread_within_a_second(wait_until):
    app, threaded, _ = slowed_app(sleep=0.5)
    app.start()
    wait_until(lambda: threaded.fused >= 2, timeout=30, what="the filter's thread to fuse")
    thread = next(t for t in threading.enumerate() if t.name == "judo-estimator")
    started = time.perf_counter()
    app.stop()
    assert time.perf_counter() - started < 1.5 and not app.running
    thread.join(1.0)  # a daemon: the update in flight ends, then the thread
    assert not thread.is_alive()


def test_config_edits_are_handed_to_the_filter_at_its_next_update(wait_until):
    app, threaded, switches = slowed_app(sleep=0.005)
    updated = app.commands.update_estimator_config({"noise_jointpos": 0.02})
    # not while it may run
    assert threaded.config is updated and threaded.estimator.config is not updated
    app.start()
    try:
        wait_until(
            lambda: threaded.estimator.config is updated, timeout=30, what="the edit handed over"
        )
        assert threaded.estimator.config.noise_jointpos == pytest.approx(0.02)
    finally:
        app.stop()
