"""Bad values sent to a running app: each is refused with its valid range, and the app keeps serving
the user's other settings. A user System whose read_state, apply or step raises is reported, and the
app recovers."""

import math
from typing import Literal

import numpy as np
import pytest

import judo
from judo.core.reading import SystemState
from judo.loop.system import System
from judo.runtime import commands
from judo.runtime.app import App

USER_SETTINGS = {
    "controller": {"max_num_traces": 3, "horizon": 0.4},
    "optimizer": {"sigma": 0.2, "num_rollouts": 12},
    "task": {"w_centered": 7.0},
}


@pytest.fixture(scope="module")
def app():
    """One running headless cart-pole app, with the user's own settings applied, shared by the
    module."""
    app = App(
        "cartpole",
        "mppi",
        controller_config=judo.ControllerConfig(
            horizon=0.3, control_freq=10.0, spline_order="linear"
        ),
        optimizer_config=judo.get_registered_optimizers()["mppi"][1](num_rollouts=8),
        gui=False,
        seed=0,
        num_workers=1,
    )
    for kind, updates in USER_SETTINGS.items():
        app.commands.update_config(kind, updates)  # type: ignore[arg-type]
    app.start()
    yield app
    app.stop()


def wait_for_plans(app: App, count: int, timeout: float = 10.0) -> None:
    import time

    start, deadline = app.stats.num_plans(), time.monotonic() + timeout
    while app.stats.num_plans() < start + count:
        assert time.monotonic() < deadline, "the app stopped planning"
        time.sleep(0.02)


@pytest.mark.parametrize(
    ("kind", "updates", "message"),
    [
        (
            "controller",
            {"horizon": np.nan},
            "ControllerConfig.horizon expects a finite number, got nan",
        ),
        (
            "controller",
            {"horizon": np.inf},
            "ControllerConfig.horizon expects a finite number, got inf",
        ),
        ("controller", {"horizon": -1.0}, "horizon must be above 0 and at most 60.0 s, got -1.0"),
        ("controller", {"horizon": 0.0}, "horizon must be above 0 and at most 60.0 s, got 0.0"),
        (
            "controller",
            {"horizon": 1e6},
            "horizon must be above 0 and at most 60.0 s, got 1000000.0",
        ),
        (
            "controller",
            {"control_freq": 0},
            "control_freq must be between 0.1 and 1000.0 Hz, got 0.0",
        ),
        (
            "controller",
            {"control_freq": 1e-9},
            "control_freq must be between 0.1 and 1000.0 Hz, got 1e-09",
        ),
        (
            "controller",
            {"control_freq": -20},
            "control_freq must be between 0.1 and 1000.0 Hz, got -20.0",
        ),
        ("controller", {"control_freq": 1e12}, "control_freq must be between 0.1 and 1000.0 Hz"),
        (
            "controller",
            {"max_opt_iters": 10**6},
            "max_opt_iters must be between 1 and 100, got 1000000",
        ),
        ("controller", {"max_opt_iters": 0}, "max_opt_iters must be between 1 and 100, got 0"),
        ("controller", {"max_num_traces": -3}, "max_num_traces must be between 0 and 64, got -3"),
        (
            "optimizer",
            {"num_rollouts": 10**7},
            "num_rollouts must be between 1 and 1048576, got 10000000",
        ),
        ("optimizer", {"num_rollouts": -1}, "num_rollouts must be between 1 and 1048576, got -1"),
        (
            "optimizer",
            {"num_rollouts": np.nan},
            "MPPIConfig.num_rollouts expects an integer, got nan",
        ),
        ("optimizer", {"num_rollouts": 10**400}, "num_rollouts must be between 1 and 1048576"),
        ("optimizer", {"num_nodes": 10**6}, "num_nodes must be between 1 and 100, got 1000000"),
        ("optimizer", {"num_nodes": 0}, "num_nodes must be between 1 and 100, got 0"),
        ("optimizer", {"sigma": np.nan}, "MPPIConfig.sigma expects a finite number, got nan"),
        ("optimizer", {"sigma": -np.inf}, "MPPIConfig.sigma expects a finite number, got -inf"),
        ("optimizer", {"sigma": 0.0}, "sigma must be positive, got 0.0"),
        ("optimizer", {"temperature": -1.0}, "temperature must be positive, got -1.0"),
        ("optimizer", {"noise_ramp": 1e300}, "noise_ramp must be above 0 and at most 100.0"),
        (
            "task",
            {"w_control": np.nan},
            "CartpoleConfig.w_control expects a finite number, got nan",
        ),
        (
            "task",
            {"w_vertical": np.inf},
            "CartpoleConfig.w_vertical expects a finite number, got inf",
        ),
    ],
)
def test_a_bad_value_is_refused_with_its_range_and_the_app_keeps_the_users_settings(
    app, kind, updates, message
):
    before = app.configs()
    with pytest.raises(judo.ConfigError) as caught:
        app.commands.update_config(kind, updates)
    assert message in str(caught.value)
    assert app.configs() == before
    wait_for_plans(app, 2)
    assert app.running and app.status.level == "info"
    controller = app.controller
    assert controller.config.max_num_traces == 3 and controller.config.horizon == 0.4
    assert controller.optimizer.config.sigma == 0.2 and controller.optimizer.num_rollouts == 12
    assert controller.task.config.w_centered == 7.0
    assert np.isfinite(controller.nominal_knots).all()


def test_rollout_buffers_beyond_the_memory_limit_are_refused_before_they_are_allocated(
    app, monkeypatch
):
    # The memory limit alone: the cycle's estimated time (about 2 s here, from the cycles measured
    # so far) is another check, which a loaded machine's slow cycles trip
    # first (tests/runtime/test_app_cycles.py has it).
    monkeypatch.setattr(commands, "MAX_CYCLE_SECONDS", math.inf)
    app.commands.update_config("optimizer", {"num_rollouts": 16384})
    with pytest.raises(judo.ConfigError, match="GiB of rollout buffers, more than the 4 GiB limit"):
        app.commands.update_config("controller", {"horizon": 60.0})
    app.commands.update_config("optimizer", {"num_rollouts": 12})
    wait_for_plans(app, 2)
    assert app.controller.config.horizon == 0.4


class FaultySystem(System):
    """A user System (a 'robot' running the cart-pole) whose chosen method raises while `fault`
    names it."""

    def __init__(self) -> None:
        self.timestep, self.steps = 0.01, 0
        self.fault: Literal["none", "read_state", "apply", "step", "nan_state"] = "none"
        self.last_action = np.zeros(1)

    def _maybe_fail(self, method: str) -> None:
        if self.fault == method:
            raise OSError(f"{method}: robot bus timeout")

    def reset(self) -> None:
        self.steps = 0

    def read_state(self) -> SystemState:
        self._maybe_fail("read_state")
        angle = np.nan if self.fault == "nan_state" else 0.1  # a sensor that returns garbage
        return SystemState(np.array([0.0, angle, 0.0, 0.0]), self.steps * self.timestep)

    def apply(self, action: np.ndarray) -> None:
        self._maybe_fail("apply")
        self.last_action = np.array(action)

    def step(self) -> None:
        self._maybe_fail("step")
        self.steps += 1


REPORTS = {
    "read_state": "read_state: robot bus timeout",
    "apply": "apply: robot bus timeout",
    "step": "step: robot bus timeout",
    "nan_state": "cannot plan from a non-finite reading",
}


@pytest.mark.parametrize("method", list(REPORTS))
def test_a_user_system_that_raises_is_reported_and_the_app_recovers(wait_until, method):
    system = FaultySystem()
    app = App("cartpole", "ps", system=system, gui=False, seed=0, num_workers=1)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 1, what="a first plan")
        system.fault = method  # type: ignore[assignment]
        wait_until(lambda: REPORTS[method] in app.status.message, what=f"the {method} report")
        assert app.status.level in ("warning", "error")
        assert app.running
        system.fault = "none"
        steps, plans = system.steps, app.stats.num_plans()
        wait_until(
            lambda: system.steps > steps + 10 and app.stats.num_plans() > plans + 1, what="recovery"
        )
        assert np.abs(system.last_action).max() <= 1.0  # cartpole's ctrlrange
    finally:
        app.stop()


def test_a_goal_move_to_a_non_finite_pose_is_refused_and_the_goal_stays():
    app = judo.App("particle", "ps", gui=False, seed=0, num_workers=1)
    goal = app.session.simulated.task.data.mocap_pos[0].copy()
    for position, quat in (
        ([np.nan, 0, 0], None),
        ([0, 0, 0], [0, 0, 0, 0]),
        ([0, np.inf, 0], [1, 0, 0, 0]),
    ):
        with pytest.raises(judo.JudoError, match="must be finite"):
            app.commands.move_goal(
                0,
                np.array(position, dtype=float),
                None if quat is None else np.array(quat, dtype=float),
            )
    with pytest.raises(judo.JudoError, match="a position needs 3 numbers"):
        app.commands.move_goal(0, np.zeros(2))
    app.commands.move_goal(0, np.array([0.1, 0.2, 0.0]))  # a finite pose is queued for the plant
    # not applied before the loops run
    assert np.array_equal(app.session.simulated.task.data.mocap_pos[0], goal)
    app.session.close()
