"""A robot whose readings stop, in a running App: the log names the readings (not planning) and how
long they have stood still, again every few seconds while they do, and ends the trouble with how
long the safe action was served and how long after the readings resumed fresh plans came. The robot
is the simulated cartpole behind a user System (wall clock, as on hardware) whose readings freeze,
as a dead robot process's last JointState does on the bridge."""

import logging
import re
import threading
import time

import pytest

import judo
from judo.core.reading import SystemState
from judo.loop.system import MujocoSystem, System
from judo.loop.timing import REPORT_EVERY
from judo.runtime.app import App

STOPPED_FOR = REPORT_EVERY + 1.5
"""Wall seconds the readings stand still: long enough for the trouble to be told twice."""


class DyingRobot(System):
    """The simulated cartpole; while `dead` is set its readings stay the last one it gave."""

    def __init__(self) -> None:
        with judo.make_controller("cartpole", "ps", seed=0) as controller:
            self.plant = MujocoSystem.from_task(controller.task, seed=0)
        self.timestep = self.plant.timestep
        self.dead = threading.Event()
        self.applied = 0
        self._last: SystemState | None = None

    def reset(self) -> None:
        self.plant.reset()

    def read_state(self) -> SystemState:
        if self.dead.is_set() and self._last is not None:
            return self._last
        self._last = self.plant.read_state()
        return self._last

    def apply(self, action) -> None:
        self.applied += 1
        self.plant.apply(action)

    def step(self) -> None:
        if not self.dead.is_set():
            self.plant.step()


def watchdog_lines(caplog, since: float) -> list[str]:
    """The watchdog's log lines (trouble and recovery) logged after wall time `since`
    (time.time())."""
    return [
        record.getMessage()
        for record in caplog.records
        if record.created >= since
        and (
            record.getMessage().startswith("watchdog: ")
            or record.getMessage().startswith("fresh plans are served")
        )
    ]


@pytest.mark.slow
def test_readings_that_stop_are_told_every_few_seconds_as_such_and_their_end_with_the_recovery_time(
    caplog, wait_until
):
    robot = DyingRobot()
    config = judo.ControllerConfig(horizon=0.3, control_freq=20.0, max_plan_age=0.3)
    caplog.set_level(logging.INFO, logger="judo.app")
    app = App(
        "cartpole", "ps", system=robot, controller_config=config, gui=False, seed=0, num_workers=1
    )
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 10, timeout=60, what="plans driving the robot")
        died = time.time()
        robot.dead.set()
        time.sleep(STOPPED_FOR)
        robot.dead.clear()
        resumed = time.time()
        wait_until(
            lambda: any(line.startswith("fresh plans") for line in watchdog_lines(caplog, resumed)),
            timeout=30,
            what="the end of the trouble in the log",
        )
    finally:
        app.stop()
    during = [line for line in watchdog_lines(caplog, died) if line.startswith("watchdog: ")]
    told = [line for line in during if "readings stopped" in line]
    assert told and during[0] == told[0], f"the first line blamed something else: {during}"
    assert len(told) >= 2, f"told once only: {during}"  # at the trip, then REPORT_EVERY s later
    stood = [float(re.search(r"not advanced for ([\d.]+) s", line).group(1)) for line in told]  # type: ignore[union-attr]
    assert stood[0] < 0.3 + 0.05 + 1.0 and stood[1] >= stood[0] + REPORT_EVERY - 0.5
    assert told[0].endswith("; serving the safe action")
    end = next(line for line in watchdog_lines(caplog, resumed) if line.startswith("fresh plans"))
    found = re.match(
        r"fresh plans are served again after ([\d.]+) s of the safe action, ([\d.]+) s after the "
        r"readings resumed: running cartpole with ps",
        end,
    )
    assert found is not None, end
    served_safe, recovery = float(found.group(1)), float(found.group(2))
    assert STOPPED_FOR - 1.5 < served_safe < STOPPED_FOR + 10 and 0 < recovery < 10
