"""A robot never gets a stale command: faults injected into a running App's System and reward.

A user System (the simulated cartpole behind a driver that can fail) records every `apply()` with
its wall time. Once plans drive the robot, one fault is switched on for a while, then cleared. While
it lasts, the watchdog must serve the task's safe action (0 for cartpole's motor) within
max_plan_age plus one control period (plus scheduling slack on a busy machine), the status line must
say why, and plans must be served again once it clears. Every time is taken from the events
themselves, not from the start, so a slow start on a loaded machine only delays the fault.
"""

import logging
import math
import threading
import time

import numpy as np
import pytest

import judo
from judo.core.reading import SystemState
from judo.loop.system import MujocoSystem, System
from judo.runtime.app import App

MAX_PLAN_AGE = 0.3
CONTROL_FREQ = 20.0
SLACK = 0.4
"""Seconds of scheduling slack on a loaded machine, beyond max_plan_age + one control period."""
FAULT_LASTS, RUN_AFTER = 1.2, 1.0
"""Wall seconds the fault lasts, and the run goes on after it clears."""
DRIVEN_FOR = 40
"""Nonzero (planned) actions in a row that show plans drive the robot before the fault starts."""


class FaultyDriver(System):
    """The simulated cartpole behind a driver whose faults a test switches on: it records every
    apply."""

    def __init__(self) -> None:
        with judo.make_controller("cartpole", "ps", seed=0) as controller:
            self.plant = MujocoSystem.from_task(controller.task, seed=0)
        self.timestep = self.plant.timestep
        self.fault: str | None = None
        self.applied: list[tuple[float, float]] = []  # (wall time, action[0])
        self.calls: list[tuple[float, str]] = []  # (wall time a call started, name)
        self.frozen: SystemState | None = None
        self.block_every_call = 0.0
        self.fault_started = self.fault_cleared = math.inf

    def _enter(self, name: str) -> None:
        self.calls.append((time.monotonic(), name))
        if self.block_every_call:
            time.sleep(self.block_every_call)

    def reset(self) -> None:
        self._enter("reset")
        self.plant.reset()

    def read_state(self) -> SystemState:
        self._enter("read_state")
        reading = self.plant.read_state()
        if self.fault == "hung reading":
            time.sleep(FAULT_LASTS)
            self.fault, self.fault_cleared = None, time.monotonic()
        elif self.fault == "raising reading":
            raise OSError("encoder bus timeout")
        elif self.fault == "NaN reading":
            reading.state[1] = np.nan
        elif self.fault == "wrong-shape reading":
            reading.state = reading.state[:3]
        elif self.fault == "frozen reading":
            self.frozen = self.frozen or reading
            return self.frozen
        return reading

    def apply(self, action: np.ndarray) -> None:
        self._enter("apply")
        if self.fault == "raising apply":
            raise OSError("drive fault")
        self.applied.append((time.monotonic(), float(action[0])))
        self.plant.apply(action)

    def step(self) -> None:
        self._enter("step")
        self.plant.step()


READING_FAULTS = [
    "hung reading",
    "raising reading",
    "NaN reading",
    "wrong-shape reading",
    "frozen reading",
]
REWARD_FAULTS = ["hung reward", "raising reward", "4 s planning cycle"]


def faulty_reward(reward, driver: FaultyDriver):
    def reward_with_faults(*args, **kwargs):
        if driver.fault in ("hung reward", "4 s planning cycle"):
            time.sleep(4.0 if driver.fault == "4 s planning cycle" else FAULT_LASTS)
        elif driver.fault == "raising reward":
            raise RuntimeError("the reward's model server is down")
        return reward(*args, **kwargs)

    return reward_with_faults


def run_with_fault(fault: str, caplog) -> tuple[FaultyDriver, App]:
    driver = FaultyDriver()
    controller = judo.ControllerConfig(
        horizon=0.3, control_freq=CONTROL_FREQ, max_plan_age=MAX_PLAN_AGE
    )
    app = App(
        "cartpole",
        "ps",
        system=driver,
        controller_config=controller,
        gui=False,
        seed=0,
        num_workers=1,
    )
    task = app.session.controller.task
    task.reward = faulty_reward(task.reward, driver)  # type: ignore[method-assign]
    caplog.set_level(logging.INFO, logger="judo.app")
    app.start()
    try:
        deadline = time.monotonic() + 30
        while not driven(driver) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert driven(driver), f"plans never drove the robot: {driver.applied[-DRIVEN_FOR:]}"
        driver.fault, driver.fault_started = fault, time.monotonic()
        time.sleep(FAULT_LASTS)
        if fault != "hung reading":  # a hung reading clears itself when its hang ends
            driver.fault, driver.fault_cleared = None, time.monotonic()
        deadline = time.monotonic() + 10
        while driver.fault is not None and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(RUN_AFTER)
    finally:
        app.stop()
    return driver, app


def driven(driver: FaultyDriver) -> bool:
    """Whether the last DRIVEN_FOR applied actions were all planned (nonzero)."""
    last = [action for _, action in driver.applied[-DRIVEN_FOR:]]
    return len(last) == DRIVEN_FOR and all(last)


@pytest.mark.slow
@pytest.mark.parametrize("fault", READING_FAULTS + REWARD_FAULTS)
def test_every_fault_gets_the_safe_action_within_max_plan_age_and_serving_resumes(fault, caplog):
    driver, app = run_with_fault(fault, caplog)
    on, off = driver.fault_started, driver.fault_cleared
    applied = np.array(driver.applied)
    times, actions = applied[:, 0], applied[:, 1]
    assert np.all(actions[times < on][-DRIVEN_FOR:] != 0.0)  # plans drove it
    deadline = on + MAX_PLAN_AGE + 1.0 / CONTROL_FREQ + SLACK
    during = actions[(times > deadline) & (times < off)]
    # nothing is applied while the driver hangs; the first apply after is safe
    if fault in ("hung reading",):
        after_hang = actions[times > off][:1]
        assert after_hang.tolist() == [0.0]
    else:
        assert len(during) > 10 and np.all(during == 0.0), f"{fault}: {during[:20]}"
    logged = caplog.text
    if fault == "hung reading":
        assert "system read_state() has not returned" in logged
    else:
        assert "watchdog:" in logged and "serving the safe action" in logged
    end = actions[times > off + RUN_AFTER - 0.4]
    if fault != "4 s planning cycle":  # that cycle is still running when the run ends
        assert len(end) > 10 and np.count_nonzero(end) > 0.8 * len(end), (
            f"{fault}: serving did not resume"
        )
        assert "fresh plans are served again" in logged or "the system responds again" in logged


@pytest.mark.slow
def test_a_driver_that_blocks_on_every_call_stops_within_1_5_s_and_gets_no_call_after(caplog):
    driver = FaultyDriver()
    app = App("cartpole", "ps", system=driver, gui=False, seed=0, num_workers=1)
    app.start()
    time.sleep(0.5)
    driver.block_every_call = 2.0
    time.sleep(2.5)  # a call is blocked now
    started = time.monotonic()
    app.stop(timeout=15)
    stopped = time.monotonic()
    assert stopped - started < 1.5
    calls_at_stop = len(driver.calls)
    time.sleep(2.5)  # the blocked call returns meanwhile
    late = [(t - stopped, name) for t, name in driver.calls[calls_at_stop:] if t > stopped]
    assert late == [], f"System calls started after stop() returned: {late}"
    assert not app.running


class HaltingDriver(FaultyDriver):
    def __init__(self) -> None:
        super().__init__()
        self.halts: list[float] = []

    def halt(self) -> bool:
        self.halts.append(time.monotonic())
        return True


def test_pause_and_stop_halt_the_robot_and_a_failed_reset_is_reported_as_a_failure(
    caplog, wait_until
):
    driver = HaltingDriver()
    caplog.set_level(logging.INFO, logger="judo.app")
    app = App("cartpole", "ps", system=driver, gui=False, seed=0, num_workers=1)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 3, what="three plans")
        app.commands.pause()
        wait_until(lambda: len(driver.halts) == 1, what="a halt on pause")
        app.commands.resume()

        def refuse_reset():
            raise OSError("cannot home the robot")

        driver.plant.reset = refuse_reset  # type: ignore[method-assign]
        app.commands.reset_task()
        wait_until(
            lambda: "system reset failed" in app.status.message, what="the failed reset reported"
        )
        assert (
            "OSError: cannot home the robot" in app.status.message and app.status.level == "error"
        )
        assert "reset to its start state" not in caplog.text
    finally:
        app.stop()
    assert len(driver.halts) == 2  # the pause, then the stop


def test_a_failed_reading_or_apply_does_not_skip_the_step_and_unserved_ticks_are_not_counted(
    wait_until,
):
    driver = FaultyDriver()
    stepped = threading.Event()
    step = driver.step

    def counting_step():
        stepped.set()
        step()

    driver.step = counting_step  # type: ignore[method-assign]
    app = App("cartpole", "ps", system=driver, gui=False, seed=0, num_workers=1)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
        for fault in ("raising reading", "raising apply"):
            driver.fault = fault
            time.sleep(0.2)
            stepped.clear()
            wait_until(stepped.is_set, what=f"a step while every call fails with a {fault}")
        sim_time = app.stats.sim_time()
        time.sleep(0.3)
        assert app.stats.sim_time() == pytest.approx(sim_time, abs=1e-9)  # no apply: no tick served
        assert app.status.message == "system apply failed: OSError: drive fault"
        driver.fault = None
        wait_until(lambda: app.stats.sim_time() > sim_time + 0.1, what="ticks served again")
    finally:
        app.stop()
