"""What the app's log says when its robot, a real plant process (`python -m judo plant`) over DDS on
loopback, is paused (SIGSTOP) and resumed (SIGCONT), then killed (SIGKILL): the readings are named,
not planning; the end of the pause is told with how long after the readings resumed fresh plans
came; a dead robot is named too."""

import dataclasses
import logging
import os
import re
import signal
import time

import pytest

pytest.importorskip("cyclonedds")

from ros2_links import free_domain, poll, start_plant, stop_process

import judo
from judo.core.configuration.registry import make_config
from judo.optimizers.mppi import MPPIConfig
from judo.ros2.bridge import Ros2System
from judo.ros2.options import Ros2Options
from judo.runtime.app import App
from judo.tasks.cartpole import Cartpole

PAUSED_FOR = 1.5
"""Wall seconds the plant process is stopped."""


def lines(caplog, since: float) -> list[str]:
    """The watchdog's lines (trouble and its end) in judo.app's log from wall time `since`
    (time.time()) on."""
    found = [record.getMessage() for record in caplog.records if record.created >= since]
    return [
        line for line in found if line.startswith(("watchdog: ", "fresh plans are served again"))
    ]


@pytest.mark.slow
def test_a_paused_then_killed_plant_is_told_as_readings_that_stopped_and_the_pause_ends_with_its_recovery_time(  # noqa: E501
    caplog,
):
    domain = free_domain()
    proc = start_plant(domain)
    system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
    config = dataclasses.replace(
        make_config(judo.ControllerConfig, "cartpole"), horizon=0.5, control_freq=20.0
    )
    optimizer = dataclasses.replace(make_config(MPPIConfig, "cartpole"), num_rollouts=16)
    app = App(
        "cartpole", "mppi", controller_config=config, optimizer_config=optimizer, system=system, gui=False, seed=0,  # noqa: E501
        num_workers=1,
    )  # fmt: skip
    caplog.set_level(logging.INFO, logger="judo.app")
    try:
        app.start()
        poll(lambda: app.stats.num_plans() >= 10, timeout=30, what="ten plans")
        paused = time.time()
        os.kill(proc.pid, signal.SIGSTOP)
        try:
            poll(
                lambda: any("readings stopped" in line for line in lines(caplog, paused)),
                what="the readings named",
            )
            time.sleep(max(0.0, paused + PAUSED_FOR - time.time()))
        finally:
            os.kill(proc.pid, signal.SIGCONT)
        resumed = time.time()
        poll(
            lambda: any(line.startswith("fresh") for line in lines(caplog, resumed)),
            timeout=20,
            what="the end",
        )
        during = [line for line in lines(caplog, paused) if line.startswith("watchdog: ")]
        end = next(line for line in lines(caplog, resumed) if line.startswith("fresh"))
        proc.kill()
        killed = time.time()
        poll(
            lambda: any("readings stopped" in line for line in lines(caplog, killed)),
            what="the dead robot named",
        )
    finally:
        app.stop()
        system.close()
        stop_process(proc)
    assert "planning stalled" not in during[-1], during  # the last word before the robot came back
    found = re.search(
        r"after ([\d.]+) s of the safe action, ([\d.]+) s after the readings resumed", end
    )
    assert found is not None, end
    print(
        f"safe action for {found.group(1)} s; fresh plans {found.group(2)} s after the readings "
        "resumed"
    )
    assert 0 < float(found.group(2)) < 5.0
