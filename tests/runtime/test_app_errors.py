"""A user's failing reward, a diverging simulation and a broken System are reported; the loops keep
running."""

from dataclasses import dataclass
from typing import Literal

import numpy as np
import pytest

import judo
from judo.core.configuration import registry
from judo.core.reading import SystemState
from judo.loop.system import System
from judo.runtime.app import App
from judo.tasks.cartpole import Cartpole, CartpoleConfig


@dataclass
class FlakyConfig(CartpoleConfig):
    """Cart-pole weights, plus a switch that breaks the reward or the simulation on purpose."""

    failure: Literal["none", "nan", "raise", "shape", "diverge"] = "none"
    """How to fail: NaN rewards, an exception in the reward, rewards of the wrong shape, or an
    absurd force on the plant."""


class FlakyCartpole(Cartpole):
    """Cart-pole whose reward or plant fails while `config.failure` says so."""

    config: FlakyConfig  # type: ignore[assignment]

    def reward(self, states, sensors, controls, config, system_metadata=None):
        if config.failure == "nan":
            return np.full(states.shape[0], np.nan)
        if config.failure == "raise":
            raise ValueError("boom in the user's reward")
        if config.failure == "shape":
            return np.zeros((states.shape[0], 2))
        return super().reward(states, sensors, controls, config, system_metadata)

    def pre_sim_step(self) -> None:
        # an absurd force: MuJoCo flags the acceleration and resets
        if self.config.failure == "diverge":
            self.data.qfrc_applied[1] = 1e30


@pytest.fixture
def flaky_app(monkeypatch, wait_until, tmp_path):
    """A running headless app on the flaky task, registered only for this test."""
    monkeypatch.setitem(registry._TASKS, "flaky_cartpole", (FlakyCartpole, FlakyConfig))
    # MuJoCo writes its warnings to MUJOCO_LOG.TXT in the working directory
    monkeypatch.chdir(tmp_path)
    app = App(
        "flaky_cartpole",
        "ps",
        controller_config=judo.ControllerConfig(horizon=0.3, control_freq=10.0),
        optimizer_config=judo.get_registered_optimizers()["ps"][1](num_rollouts=8),
        gui=False,
        seed=0,
        num_workers=1,
    )
    app.start()
    wait_until(lambda: app.stats.num_plans() >= 1, what="a first plan")
    yield app
    app.stop()


def keeps_running(app: App, wait_until) -> None:
    """Sim time advances, and once the failure is switched off, planning resumes."""
    sim_time = app.stats.sim_time()
    wait_until(lambda: app.stats.sim_time() > sim_time + 0.2, what="sim time to advance")
    app.commands.update_config("task", {"failure": "none"})
    plans = app.stats.num_plans()
    wait_until(lambda: app.stats.num_plans() >= plans + 2, what="planning to resume")
    assert app.running


@pytest.mark.parametrize(
    ("failure", "level", "message"),
    [
        (
            "nan",
            "warning",
            "planning cycle skipped: all 8 rollouts of FlakyCartpole scored NaN or -inf",
        ),
        (
            "raise",
            "error",
            "planning cycle skipped: ValueError in flaky_cartpole: boom in the user's reward",
        ),
        (
            "shape",
            "warning",
            "planning cycle skipped: FlakyCartpole.reward returned shape (8, 2), expected (8,)",
        ),
    ],
)
def test_a_failing_reward_skips_cycles_is_reported_and_the_loops_survive(
    flaky_app, wait_until, caplog, failure, level, message
):
    with caplog.at_level("WARNING", logger="judo.app"):
        plans = flaky_app.stats.num_plans()
        flaky_app.commands.update_config("task", {"failure": failure})
        wait_until(
            lambda: flaky_app.status.message.startswith(message), what=f"the status {message!r}"
        )
        assert flaky_app.status.level == level
        assert flaky_app.stats.num_plans() <= plans + 2  # failed cycles publish no plan
        keeps_running(flaky_app, wait_until)
    assert any(record.getMessage().startswith(message) for record in caplog.records)


def test_a_diverging_simulation_is_reset_reported_and_the_loops_survive(flaky_app, wait_until):
    flaky_app.commands.update_config("task", {"failure": "diverge"})
    wait_until(lambda: "diverged" in flaky_app.status.message, what="the divergence report")
    assert flaky_app.status.message.startswith("simulation of FlakyCartpole diverged at t=")
    assert flaky_app.status.level == "warning"
    keeps_running(flaky_app, wait_until)
    assert np.isfinite(flaky_app.buffer.latest("system").value.reading.state).all()


class BrokenSensor(System):
    """A user System whose step fails every other call."""

    def __init__(self) -> None:
        self.timestep, self.steps = 0.01, 0

    def reset(self) -> None:
        self.steps = 0

    def read_state(self) -> SystemState:
        return SystemState(np.array([0.0, np.pi, 0.0, 0.0]), self.steps * self.timestep)

    def apply(self, action: np.ndarray) -> None:
        pass

    def step(self) -> None:
        self.steps += 1
        if self.steps % 2:
            raise OSError("sensor cable unplugged")


def test_a_failing_user_system_is_reported_and_the_loops_survive(wait_until):
    system = BrokenSensor()
    app = App("cartpole", "ps", system=system, gui=False, seed=0, num_workers=1)
    app.start()
    try:
        wait_until(
            lambda: app.status.message == "system step failed: OSError: sensor cable unplugged",
            what="report",
        )
        assert app.status.level == "error"
        steps = system.steps
        wait_until(lambda: system.steps > steps + 10, what="more steps")
        assert app.running
    finally:
        app.stop()
