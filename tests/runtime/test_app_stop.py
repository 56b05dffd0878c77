"""`App.stop()` takes effect within about a second whatever the configs: the longest control period,
the most optimizer iterations a cycle, a reward that sleeps 1 s, or one huge batch of rollouts."""

import threading
import time

import numpy as np
import pytest

import judo
from judo.core.configuration import registry
from judo.core.configuration.controller_config import MAX_OPT_ITERS, MIN_CONTROL_FREQ
from judo.runtime.app import App
from judo.tasks.cartpole import Cartpole, CartpoleConfig

STOP_BUDGET = 1.0
"""Seconds `stop()` may take (a stop takes effect within about a second)."""


class SlowRewardCartpole(Cartpole):
    """Cart-pole whose reward takes 1 s, as a careless user reward might."""

    def reward(self, states, sensors, controls, config, system_metadata=None):
        time.sleep(1.0)
        return super().reward(states, sensors, controls, config, system_metadata)


def judo_threads() -> list[str]:
    return sorted(t.name for t in threading.enumerate() if t.name.startswith("judo"))


def started(task: str = "cartpole", *, controller: dict, num_rollouts: int = 8) -> App:
    optimizer_config = judo.get_registered_optimizers()["ps"][1](num_rollouts=num_rollouts)
    controller_config = judo.ControllerConfig(
        **{"horizon": 0.3, "control_freq": 10.0, **controller}
    )
    app = App(
        task,
        "ps",
        controller_config=controller_config,
        optimizer_config=optimizer_config,
        gui=False,
        seed=0,
        num_workers=2,
    )
    app.start()
    return app


def stop_time(app: App) -> float:
    start = time.perf_counter()
    app.stop(timeout=30)
    elapsed = time.perf_counter() - start
    assert not app.running and not app._thread.is_alive()
    return elapsed


def test_stop_cuts_a_long_control_period_short(wait_until):
    app = started(controller={"control_freq": MIN_CONTROL_FREQ})  # one plan every 10 s
    wait_until(lambda: app.stats.num_plans() >= 1, what="the first plan")
    time.sleep(0.2)  # the controller loop now sleeps out its period
    assert stop_time(app) < STOP_BUDGET
    # The idle planning thread is joined by the stop; allow a loaded machine a moment to schedule
    # it.
    wait_until(lambda: judo_threads() == [], timeout=1.0, what="no judo thread left")


def in_flight_for(app: App, seconds: float):
    """A condition for wait_until: one planning cycle has been in flight for `seconds` of wall time,
    and the plant has run (judo's simulator waits for a cycle that takes more than one control
    period of sim time)."""
    seen: list[float] = []

    def condition() -> bool:
        if app.session.closed_loop.cycle_started is None or app.stats.sim_time() <= 0.0:
            seen.clear()
            return False
        seen[:] = seen or [time.perf_counter()]
        return time.perf_counter() - seen[0] >= seconds

    return condition


def test_stop_ends_a_cycle_of_the_most_optimizer_iterations(wait_until):
    app = started(controller={"max_opt_iters": MAX_OPT_ITERS}, num_rollouts=1024)  # seconds a cycle
    wait_until(in_flight_for(app, 0.3), what="a planning cycle in flight for 0.3 s")
    assert app.stats.num_plans() == 0  # the first cycle is still iterating
    assert stop_time(app) < STOP_BUDGET
    wait_until(
        lambda: judo_threads() == [],
        timeout=3.0,
        what="the planning thread to end its last iteration",
    )


def test_stop_does_not_wait_for_a_slow_user_reward(monkeypatch, wait_until):
    monkeypatch.setitem(registry._TASKS, "slow_cartpole", (SlowRewardCartpole, CartpoleConfig))
    app = started("slow_cartpole", controller={})
    # a reward sleeps now
    wait_until(in_flight_for(app, 0.3), what="a planning cycle in flight for 0.3 s")
    assert stop_time(app) < STOP_BUDGET
    wait_until(lambda: judo_threads() == [], timeout=2.0, what="the abandoned reward call to end")


def test_stop_abandons_one_huge_batch_of_rollouts(wait_until):
    app = started(controller={}, num_rollouts=100_000)
    wait_until(in_flight_for(app, 0.2), what="a planning cycle in flight for 0.2 s")
    assert stop_time(app) < STOP_BUDGET
    # the rollout threads finish their chunk in their own time; they are daemons, so they never hold
    # up an exit
    assert all(t.daemon for t in threading.enumerate() if t.name.startswith("judo"))


def test_a_stop_before_the_loops_start_ends_the_run_at_once():
    app = App("cartpole", "ps", gui=False, num_workers=1)
    app.stop()
    start = time.perf_counter()
    summary = app.run()
    assert time.perf_counter() - start < STOP_BUDGET and summary.num_plans == 0


def test_lowering_control_freq_is_followed_without_waiting_out_the_old_period(wait_until):
    app = started(controller={"control_freq": MIN_CONTROL_FREQ})
    try:
        wait_until(lambda: app.stats.num_plans() >= 1, what="the first plan")
        app.commands.update_config("controller", {"control_freq": 10.0})
        wait_until(lambda: app.stats.num_plans() >= 4, timeout=5.0, what="plans at the new rate")
    finally:
        app.stop()


@pytest.mark.parametrize("cancel_after", [0, 3])
def test_update_action_stops_between_iterations_when_cancelled(upright_task, cancel_after):
    optimizer_cls, config_cls = judo.get_registered_optimizers()["ps"]
    optimizer = optimizer_cls(config_cls(num_rollouts=4, num_nodes=4), upright_task.nu)
    controller = judo.Controller(
        judo.ControllerConfig(max_opt_iters=100), upright_task, optimizer, num_workers=1
    )
    cancel = threading.Event()
    calls = []
    sample = optimizer.sample_control_knots

    def counting_sample(nominal):
        calls.append(1)
        if len(calls) >= cancel_after:
            cancel.set()
        return sample(nominal)

    optimizer.sample_control_knots = counting_sample  # type: ignore[method-assign]
    if cancel_after == 0:
        cancel.set()
    with pytest.raises(judo.JudoError, match="planning cycle cancelled"):
        controller.update_action(np.zeros(4), 0.0, cancel=cancel)
    assert len(calls) == cancel_after and controller.nominal_knots is None  # no plan half-made
    controller.close()
