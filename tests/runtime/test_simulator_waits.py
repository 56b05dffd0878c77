"""With a slow planner, judo's own simulator waits for it; a user's System (a robot) gets the safe
action.

The planner is slowed by a reward that sleeps SLOW_REWARD s per call, well past one control period
and past max_plan_age. The app's simulator must then never trip the watchdog, run slower than real
time, and serve plans no cycle of which took more than one control period of sim time; the same
planner driving a user's System (the simulator behind a thin driver) must trip the watchdog and
serve the safe action.
"""

import time

import numpy as np

import judo
from judo.core.reading import SystemState
from judo.loop.system import MujocoSystem, System
from judo.runtime.app import App

SLOW_REWARD = 0.25
CONTROL_FREQ = 20.0
MAX_PLAN_AGE = 0.1
RUN_SECONDS = 2.5


class Driver(System):
    """The simulated cartpole behind a user's System: the app treats it as a robot."""

    def __init__(self) -> None:
        with judo.make_controller("cartpole", "ps", seed=0) as controller:
            self.plant = MujocoSystem.from_task(controller.task, seed=0)
        self.timestep = self.plant.timestep
        self.applied: list[float] = []

    def reset(self) -> None:
        self.plant.reset()

    def read_state(self) -> SystemState:
        return self.plant.read_state()

    def apply(self, action: np.ndarray) -> None:
        self.applied.append(float(action[0]))
        self.plant.apply(action)

    def step(self) -> None:
        self.plant.step()


def run_slowed(system: System | None) -> App:
    controller = judo.ControllerConfig(
        horizon=0.3, control_freq=CONTROL_FREQ, max_plan_age=MAX_PLAN_AGE
    )
    app = App(
        "cartpole",
        "ps",
        system=system,
        controller_config=controller,
        gui=False,
        seed=0,
        num_workers=1,
    )
    task = app.session.controller.task
    reward = task.reward

    def slow_reward(*args, **kwargs):
        time.sleep(SLOW_REWARD)
        return reward(*args, **kwargs)

    task.reward = slow_reward  # type: ignore[method-assign]
    app.start()
    try:
        time.sleep(RUN_SECONDS)
    finally:
        app.stop()
    return app


def test_judos_simulator_waits_for_a_slow_planner_and_the_watchdog_never_trips():
    app = run_slowed(None)
    loop = app.session.closed_loop
    period = 1.0 / CONTROL_FREQ
    assert app.stats.num_plans() >= 3
    assert loop.watchdog.trips == 0 and loop.watchdog.tripped is None
    # the simulation ran slower than real time: about one control period per cycle of >= SLOW_REWARD
    # s
    assert 0.0 < app.stats.sim_time() < 0.6 * RUN_SECONDS
    # no cycle took more than one control period (and a step) of sim time
    assert loop.last_cycle_plant_time <= period + loop.system.timestep + 1e-9


def test_a_users_system_is_not_held_back_and_gets_the_safe_action_from_the_same_slow_planner():
    driver = Driver()
    app = run_slowed(driver)
    loop = app.session.closed_loop
    # the plan grew older than max_plan_age + one period of wall time
    assert loop.watchdog.trips >= 1
    assert 0.0 in driver.applied  # cartpole's safe action: the motor off
    # the robot's time is never slowed for the planner
    assert app.stats.sim_time() > 0.6 * RUN_SECONDS


def test_the_apps_pendulum_swings_up_within_10_s_of_sim_time_however_slow_the_machine():
    """The new-user tour's pendulum (mppi at its defaults): upright (within 0.3 rad) by 10 s of sim
    time, read off the app's own plant while it runs at whatever pace this machine allows."""
    app = App("pendulum", "mppi", gui=False, seed=0, duration=10.0, num_workers=1)
    plant = app.session.simulated
    assert plant is not None
    upright_at = None
    app.start()
    try:
        deadline = time.monotonic() + 120.0
        while app.stats.sim_time() < 9.9 and time.monotonic() < deadline:
            time.sleep(0.05)
            if upright_at is None and np.cos(plant.task.data.qpos[0]) > np.cos(0.3):
                upright_at = app.stats.sim_time()
    finally:
        app.stop()
    assert upright_at is not None and upright_at < 10.0, (
        f"the pole was not upright by {app.stats.sim_time():.1f} s"
    )
    assert np.cos(plant.task.data.qpos[0]) > np.cos(0.3)  # and it stays up
    assert app.session.closed_loop.watchdog.trips == 0


def test_judos_simulator_does_not_wait_for_a_failing_planner_the_watchdog_serves_the_safe_action():
    controller = judo.ControllerConfig(
        horizon=0.3, control_freq=CONTROL_FREQ, max_plan_age=MAX_PLAN_AGE
    )
    app = App("cartpole", "ps", controller_config=controller, gui=False, seed=0, num_workers=1)

    def failing_reward(*args, **kwargs):
        raise RuntimeError("the reward's model server is down")

    app.session.controller.task.reward = failing_reward  # type: ignore[method-assign]
    app.start()
    try:
        time.sleep(1.5)
    finally:
        app.stop()
    loop = app.session.closed_loop
    assert app.stats.num_plans() == 0 and loop.last_cycle_failed
    assert loop.watchdog.trips >= 1 and app.stats.sim_time() > MAX_PLAN_AGE + 1.0 / CONTROL_FREQ
