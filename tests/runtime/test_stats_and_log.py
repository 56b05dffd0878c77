"""RunStats stays bounded over a long run; App.report logs each message at most once per interval,
however messages alternate."""

import logging

import numpy as np
import pytest

from judo.runtime import status as app_module
from judo.runtime.app import App
from judo.runtime.exchange import PLAN_TIMES_KEPT, RunStats


def test_run_stats_keep_a_bounded_window_of_plan_times_but_count_and_average_them_all():
    stats = RunStats()
    durations = np.r_[np.full(PLAN_TIMES_KEPT, 0.010), np.full(PLAN_TIMES_KEPT * 2, 0.001)]
    for i, duration in enumerate(durations):
        stats.record_plan(0.01 * i, float(duration), -1.0)
    assert len(stats._plan_times) == PLAN_TIMES_KEPT
    summary = stats.summary("cartpole", "mppi")
    assert summary.num_plans == stats.num_plans() == 3 * PLAN_TIMES_KEPT
    assert summary.plan_time_mean_ms == pytest.approx(1000 * durations.mean())
    assert summary.plan_time_p95_ms == pytest.approx(1.0)  # over the kept window
    assert summary.control_rate == pytest.approx(100.0)


def test_alternating_messages_cannot_flood_the_log(monkeypatch, caplog):
    clock = [100.0]
    monkeypatch.setattr(app_module.time, "monotonic", lambda: clock[0])
    app = App("cartpole", "ps", gui=False, num_workers=1)
    with caplog.at_level(logging.INFO, logger="judo.app"):
        for i in range(1000):  # 1000 reports in 1 s, two messages taking turns
            clock[0] += 0.001
            app.report(
                "system read_state failed: OSError: a"
                if i % 2
                else "system step failed: OSError: b",
                "error",
            )
        assert len(caplog.records) == 2
        assert (
            app.status.message == "system read_state failed: OSError: a"
            and app.status.count == 1000
        )
        clock[0] += app_module.REPEAT_LOG_INTERVAL
        app.report("system step failed: OSError: b", "error")
        assert len(caplog.records) == 3  # once the interval is over, the message is logged again
