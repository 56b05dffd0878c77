"""A planning cycle the user cannot wait for: its cost is shown, an edit that would make it longer
than MAX_CYCLE_SECONDS is refused, and a cycle in flight is cancelled by a pause, a reset, a switch
or a resize."""

import threading
import time

import numpy as np
import pytest

import judo
from judo.core.configuration import registry
from judo.core.errors import ConfigError, JudoError
from judo.core.planner_view import CycleSize
from judo.core.rollouts.rollout import RolloutPool
from judo.runtime.app import App
from judo.runtime.exchange import MAX_CYCLE_SECONDS, StepCost
from judo.tasks.cartpole import Cartpole, CartpoleConfig

CANCEL_BUDGET = 3.0
"""Seconds from a command to the end of the cycle it cancels (a piece of rollouts: well under a
second idle, and more than 1.5 s on a CI machine at a load of 15 on its 2 cores)."""


def big_app(num_rollouts: int = 20_000) -> App:
    """Cart-pole whose every cycle takes tens of seconds: 20 iterations of 20,000 rollouts of 200
    steps."""
    controller = judo.ControllerConfig(horizon=2.0, max_opt_iters=20, control_freq=10.0)
    optimizer = judo.get_registered_optimizers()["ps"][1](num_rollouts=num_rollouts)
    app = App(
        "cartpole",
        "ps",
        controller_config=controller,
        optimizer_config=optimizer,
        gui=False,
        num_workers=2,
    )
    app.start()
    return app


def late_cycle(app: App):
    """A condition: a planning cycle has been in flight longer than LATE_CYCLE (the status line
    counts it)."""
    return lambda: (
        app.planning_cost().running_for is not None and app.status.message.startswith("planning: ")
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("command", "reason"),
    [
        ("pause", "paused"),
        ("reset_task", "the task was reset"),
        ("switch", "switching to cartpole with mppi"),
        ("resize", "the planning cycle was resized"),
    ],
)
def test_a_late_cycle_is_cancelled_by_the_user(wait_until, command, reason):
    app = big_app()
    try:
        wait_until(late_cycle(app), what="a late planning cycle")
        cycle = app._state.cycle
        assert cycle is not None
        start = time.perf_counter()
        if command == "pause":
            app.commands.pause()
        elif command == "reset_task":
            app.commands.reset_task()
        elif command == "switch":
            app.commands.switch_optimizer("mppi")
        else:
            app.commands.update_config("optimizer", {"num_rollouts": 64})
        wait_until(
            lambda: app._state.cycle is not cycle, timeout=CANCEL_BUDGET, what="the cycle to end"
        )
        assert time.perf_counter() - start < CANCEL_BUDGET
        assert app.stats.num_plans() == 0  # cancelled, not completed
        assert app.summary().num_plans == 0
        assert cycle.reason == reason
        # the simulator waited for the cycle: the run's wall time holds the wait
        summary = app.summary()
        assert summary.wall_time > 1.0 and summary.real_time_factor < 0.5, summary
        if command == "switch":
            wait_until(lambda: app.session.optimizer_name == "mppi", timeout=5.0, what="the switch")
        # planning goes on, at the new size or in the new session
        if command in ("switch", "resize"):
            wait_until(
                lambda: app.stats.num_plans() >= 1,
                timeout=10.0,
                what="a plan after the cancelled cycle",
            )
    finally:
        app.stop()


def test_an_edit_whose_cycle_would_be_too_long_is_refused_and_a_smaller_one_is_not():
    app = App("cartpole", "ps", gui=False, num_workers=1)
    try:
        app.commands.update_config(
            "controller", {"horizon": 2.0, "max_opt_iters": 10, "num_randomizations": 8}
        )
        before = app.configs()["optimizer"]
        cost = app.planning_cost()
        size = CycleSize(before.num_rollouts, 8, 10, 200)
        assert cost.size == size and np.isnan(cost.last) and cost.running_for is None
        with pytest.raises(ConfigError) as refused:
            app.commands.update_config("optimizer", {"num_rollouts": 20_000})
        estimate = app._state.step_cost.estimate(CycleSize(20_000, 8, 10, 200))
        assert estimate > MAX_CYCLE_SECONDS
        assert str(refused.value) == (
            f"num_rollouts = 20000 would make a planning cycle of about {estimate:.0f} s "
            "(num_rollouts x "
            "num_randomizations x iterations x horizon steps: 20000 x 8 x 10 x 200 = "
            "320,000,000 steps); "
            f"expected at most {MAX_CYCLE_SECONDS:g} s: lower num_rollouts, "
            "num_randomizations, max_opt_iters, "
            "iterations_per_second or "
            "the horizon"
        )
        assert app.configs()["optimizer"] is before  # nothing changed
        app.commands.update_config("controller", {"max_opt_iters": 1})  # smaller: accepted
        assert app.planning_cost().size == CycleSize(before.num_rollouts, 8, 1, 200)
    finally:
        app.stop()


def test_the_step_cost_is_probed_then_measured_from_large_cycles():
    model = judo.make_controller("cartpole", "ps", num_workers=1)
    try:
        cost = StepCost(model.task.model, 1)
        assert 0 < cost.seconds < 1e-3
        probed = cost.seconds
        cost.record(CycleSize(10, 1, 1, 10), 1e-9)  # a small cycle never lowers it below the probe
        assert cost.seconds == probed
        # its overhead counts as steps: the estimate errs high
        cost.record(CycleSize(10, 1, 1, 10), 5.0)
        assert cost.seconds == pytest.approx(0.05)
        cost.record(CycleSize(1000, 1, 1, 100), 0.5)
        assert cost.seconds == pytest.approx(5e-6)
        assert cost.estimate(CycleSize(2000, 2, 1, 100)) == pytest.approx(2.0)
    finally:
        model.close()


def test_one_slow_cycle_does_not_inflate_the_estimate_that_refuses_edits():
    model = judo.make_controller("cartpole", "ps", num_workers=1)
    try:
        cost, small = StepCost(model.task.model, 1), CycleSize(64, 1, 1, 40)
        for _ in range(4):
            cost.record(small, 2560 * 4e-5)  # 40 us a step
        cost.record(small, 1.0)  # a page loading held this cycle up: 390 us a step
        big = CycleSize(64, 1, 1, 800)  # the horizon typed up to 8 s
        usual = max(cost.probed, 4e-5)  # a small cycle never counts below the probe
        # the median of the recent cycles
        assert cost.estimate(big) == pytest.approx(51_200 * usual)
        assert cost.estimate(big) < MAX_CYCLE_SECONDS
        assert cost.seconds == pytest.approx(1.0 / 2560)  # what the last cycle alone says
        assert 51_200 * cost.seconds > MAX_CYCLE_SECONDS  # it alone would have refused the edit
    finally:
        model.close()


def test_a_cancelled_batch_ends_part_way_and_a_whole_one_matches_one_call(upright_task):
    pool = RolloutPool(upright_task.model, num_workers=2)
    try:
        rng = np.random.default_rng(0)
        # 120,000 steps: 2 pieces a worker
        controls = rng.uniform(-1, 1, (40, 3000, upright_task.model.nu))
        state = np.zeros(pool.nstate)
        whole = [a.copy() for a in pool.rollout(state, controls)]
        never = threading.Event()
        pool.set_cancel(never)
        pieces = pool.rollout(state, controls)
        assert all(np.array_equal(a, b) for a, b in zip(whole, pieces, strict=True))  # bit for bit
        cancelled = threading.Event()
        cancelled.set()
        pool.set_cancel(cancelled)
        with pytest.raises(
            JudoError, match="planning cycle cancelled part-way through a batch of rollouts"
        ):
            pool.rollout(state, controls)
    finally:
        pool.close()


class PausingCartpole(Cartpole):
    """Cart-pole whose simulator stalls once for 0.8 s, as this process does while a page is sent
    the scene."""

    stalled = False

    def pre_sim_step(self) -> None:
        if not PausingCartpole.stalled and self.data.time > 0.2:
            PausingCartpole.stalled = True
            time.sleep(0.8)


def test_judos_own_simulator_is_never_reported_as_a_blocked_driver(monkeypatch, wait_until, caplog):
    monkeypatch.setitem(registry._TASKS, "pausing_cartpole", (PausingCartpole, CartpoleConfig))
    PausingCartpole.stalled = False
    app = App("pausing_cartpole", "ps", gui=False, num_workers=1, system_call_limit=0.3)
    app.start()
    try:
        wait_until(
            lambda: PausingCartpole.stalled and app.stats.sim_time() > 0.5,
            what="the stall and after",
        )
    finally:
        app.stop()
    assert "has not returned" not in caplog.text and "responds again" not in caplog.text


def test_the_extra_iterations_of_a_slow_rate_stop_at_the_control_period(wait_until):
    # 500 iterations a second at 5 Hz asks for 100 a cycle, about 5 s of rollouts; the app gives
    # each cycle its
    # 0.2 s period, so it runs the required one and as many more as fit.
    controller = judo.ControllerConfig(horizon=1.0, control_freq=5.0, iterations_per_second=500.0)
    optimizer = judo.get_registered_optimizers()["ps"][1](num_rollouts=512)
    app = App(
        "cartpole",
        "ps",
        controller_config=controller,
        optimizer_config=optimizer,
        gui=False,
        num_workers=1,
    )
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 3, what="three plans")
        assert 1 <= app.controller.iterations_run < 100
        cost = app.planning_cost()
        assert cost.size is not None and cost.size.iterations == 100
        # what the GUI shows counts the deadline
        assert cost.estimate < app._state.step_cost.estimate(cost.size)
    finally:
        app.stop()
