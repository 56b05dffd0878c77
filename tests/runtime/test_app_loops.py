"""The App's real loops, headless: real-time pace, control rate, commands, switches and a user
System."""

import time

import numpy as np
import pytest

import judo
from judo.core.configuration.registry import make_config
from judo.core.errors import JudoError
from judo.core.reading import SystemState
from judo.loop.system import System
from judo.runtime.app import App

CARTPOLE_HORIZON = make_config(judo.ControllerConfig, "cartpole").horizon
"""cartpole's default horizon (src/judo/tasks/models/cartpole.toml)."""


def small_app(task: str = "cartpole", optimizer: str = "mppi", **kwargs) -> App:
    """A headless app with a small planning problem, so it keeps up on a busy machine."""
    controller = judo.ControllerConfig(horizon=0.3, control_freq=10.0, spline_order="linear")
    optimizer_cls = judo.get_registered_optimizers()[optimizer][1]
    return App(
        task,
        optimizer,
        controller_config=controller,
        optimizer_config=optimizer_cls(num_rollouts=8),
        gui=False,
        seed=0,
        num_workers=1,
        **kwargs,
    )


def latest_plan_steps(app: App) -> int:
    """Steps T of the latest published plan's traces, or 0 before the first plan."""
    plan = app.buffer.latest("plan")
    return 0 if plan is None else plan.value.traces.shape[1]


def test_headless_run_keeps_real_time_and_plans_at_control_freq():
    app = small_app(duration=2.0)
    start = time.perf_counter()
    summary = app.run()
    wall = time.perf_counter() - start
    assert summary.sim_time == pytest.approx(2.0, abs=0.02)
    assert 0.75 < summary.sim_time / wall < 1.25  # sim time follows the wall clock...
    assert 0.8 < summary.real_time_factor < 1.2
    assert 6.0 < summary.control_rate < 11.0  # ...and plans arrive at about control_freq = 10 Hz
    assert summary.num_plans >= 12
    assert (summary.task, summary.optimizer) == ("cartpole", "mppi")
    assert np.isfinite(summary.final_reward) and np.isfinite(summary.plan_time_p95_ms)


def test_start_returns_at_once_and_stop_ends_every_loop(wait_until):
    app = small_app()
    app.start()
    assert app.running
    wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
    plan = app.buffer.latest("plan").value
    assert plan.nominal_knots.shape == (app.controller.optimizer.num_nodes, 1)
    assert plan.traces.shape[0] == 1 + min(app.controller.config.max_num_traces, 8)
    app.stop()
    assert not app.running
    with pytest.raises(JudoError, match="already run"):
        app.start()


def test_wait_returns_when_the_duration_is_reached():
    app = small_app(duration=0.5)
    app.start()
    assert app.wait(timeout=30)
    assert not app.running
    assert app.summary().sim_time == pytest.approx(0.5, abs=0.02)


def test_pause_freezes_sim_time_and_resume_continues(wait_until):
    app = small_app()
    app.start()
    try:
        wait_until(lambda: app.stats.sim_time() > 0.2, what="sim time to pass 0.2 s")
        app.commands.pause()
        time.sleep(0.1)
        frozen = app.buffer.latest("system").value.reading.time
        plans = app.stats.num_plans()
        time.sleep(0.3)
        assert app.buffer.latest("system").value.reading.time == frozen
        assert app.stats.num_plans() <= plans + 1  # at most the cycle that was in flight
        app.commands.resume()
        wait_until(
            lambda: app.buffer.latest("system").value.reading.time > frozen + 0.1,
            what="sim to resume",
        )
    finally:
        app.stop()


def test_config_edit_reaches_the_controller_at_the_next_cycle(wait_until):
    app = small_app()
    app.start()
    try:
        app.commands.update_config("controller", {"horizon": 0.5})
        app.commands.update_config("optimizer", {"sigma": 0.4})
        # One cycle applies the controller config, then the optimizer's: wait for both, not the
        # first alone.
        wait_until(
            lambda: (
                app.controller.config.horizon == 0.5
                and app.controller.optimizer.config.sigma == 0.4
            ),
            what="the horizon and sigma edits",
        )
        wait_until(lambda: latest_plan_steps(app) == 50, what="a plan over 50 steps")
        app.commands.reset_configs()
        wait_until(
            lambda: (
                app.controller.config.horizon == CARTPOLE_HORIZON
                and app.controller.optimizer.config.sigma == 0.3
            ),
            what="cartpole's default horizon and sigma",
        )
    finally:
        app.stop()


def test_a_task_config_edit_reaches_the_plant_from_the_planners_task(wait_until):
    app = small_app()
    app.start()
    try:
        app.commands.update_config("task", {"w_vertical": 7.0})
        # one Task instance owns the config (the planner's); the simulated plant's task reads it on
        # its own thread
        wait_until(
            lambda: app.controller.task.config.w_vertical == 7.0, what="the edit at the planner"
        )
        wait_until(
            lambda: app.session.simulated.task.config is app.controller.task.config,
            what="the plant",
        )
    finally:
        app.stop()


@pytest.mark.parametrize(
    ("kind", "updates", "message"),
    [
        ("optimizer", {"num_rollouts": 0}, "num_rollouts must be between 1 and 1048576, got 0"),
        (
            "controller",
            {"horizon": 0.001},
            r"horizon \(0.001 s\) is shorter "
            r"than one timestep \(0.01 s\)",
        ),
        (
            "controller",
            {"spline_order": "quintic"},
            "expects one of \\['zero', 'linear', 'cubic'\\]",
        ),
        ("task", {"no_such_weight": 1.0}, "unknown field of CartpoleConfig 'no_such_weight'"),
    ],
)
def test_invalid_edit_is_refused_and_the_previous_config_stays(kind, updates, message):
    app = small_app()
    before = app.configs()[kind]
    with pytest.raises(JudoError, match=message):
        app.commands.update_config(kind, updates)
    assert app.configs()[kind] is before
    assert app.controller.config.horizon == 0.3


def test_a_control_rate_below_the_task_minimum_is_applied_with_a_warning():
    app = small_app("acrobot")  # Acrobot.min_control_freq: 50 Hz
    updated = app.commands.update_config("controller", {"control_freq": 20.0})
    assert updated.control_freq == 20.0
    assert app.status.level == "warning"
    assert (
        "control_freq 20 Hz is below the 50 Hz that Acrobot's defaults need" in app.status.message
    )
    reports = app.status.count
    app.commands.update_config("controller", {"control_freq": 50.0})
    assert app.status.count == reports  # at the minimum: no warning


def test_edits_for_a_replaced_session_are_refused():
    app = small_app()
    with pytest.raises(JudoError, match="the task or optimizer changed since this edit was made"):
        app.commands.update_config(
            "controller", {"horizon": 0.5}, generation=app.session.generation + 1
        )


def test_switching_optimizer_mid_run_keeps_the_plant_and_the_tuned_configs(wait_until):
    app = small_app()
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 2, what="two plans")
        old = app.session
        app.commands.switch_optimizer("cem")
        wait_until(lambda: app.session.optimizer_name == "cem", what="the switch to cem")
        new = app.session
        assert new.system is old.system and new.generation == old.generation + 1
        assert type(new.controller.optimizer).__name__ == "CEM"
        assert new.controller.config.horizon == 0.3  # the tuned controller config carried over
        assert old.controller.backend._executor._shutdown  # the old rollout threads were stopped
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 2, what="plans from cem")
        assert app.buffer.latest("plan").value.generation == new.generation
    finally:
        app.stop()


def test_switching_task_mid_run_builds_a_new_plant_with_the_task_defaults(wait_until):
    app = small_app()
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 1, what="a plan")
        app.commands.switch_task("cylinder_push")
        wait_until(
            lambda: app.session.task_name == "cylinder_push", what="the switch to cylinder_push"
        )
        assert app.session.optimizer_name == "mppi"
        assert type(app.configs()["task"]).__name__ == "CylinderPushConfig"
        wait_until(
            lambda: app.buffer.latest("system").value.reading.state.shape == (8,),
            what="the new plant's state",
        )
        plans = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= plans + 2, what="plans on the new task")
        assert "switched to cylinder_push with mppi" in app.status.message
    finally:
        app.stop()


def test_unknown_names_are_refused_with_the_valid_choices():
    tasks, optimizers = (
        ", ".join(sorted(judo.get_registered_tasks())),
        ", ".join(sorted(judo.get_registered_optimizers())),
    )
    with pytest.raises(JudoError) as refused:
        small_app("nope")
    assert str(refused.value) == f"unknown task 'nope'; valid tasks are: {tasks}"
    app = small_app()
    with pytest.raises(JudoError) as refused:
        app.commands.switch_optimizer("nope")
    assert str(refused.value) == f"unknown optimizer 'nope'; valid optimizers are: {optimizers}"


class Clock(System):
    """A plant without MuJoCo: the cart-pole state never changes; only time passes. Counts its
    calls."""

    def __init__(self) -> None:
        self.timestep, self.time, self.steps, self.resets = 0.01, 0.0, 0, 0
        self.actions: list[np.ndarray] = []

    def reset(self) -> None:
        self.resets += 1

    def read_state(self) -> SystemState:
        return SystemState(np.array([0.0, np.pi, 0.0, 0.0]), self.time)

    def apply(self, action: np.ndarray) -> None:
        self.actions.append(np.array(action))

    def step(self) -> None:
        self.steps += 1
        self.time = self.steps * self.timestep


def test_a_user_system_is_driven_in_place_of_the_simulator(wait_until):
    clock = Clock()
    app = small_app(system=clock)
    app.start()
    try:
        wait_until(lambda: app.stats.num_plans() >= 3, what="three plans")
        assert app.session.simulated is None and app.session.system is clock
        assert clock.steps > 0 and len(clock.actions) == clock.steps
        assert all(action.shape == (1,) for action in clock.actions)
        app.commands.reset_task()
        wait_until(lambda: clock.resets == 1, what="the reset to reach the user's system")
        with pytest.raises(
            JudoError, match="cannot switch to task 'cylinder_push': the app drives your own System"
        ):
            app.commands.switch_task("cylinder_push")
        app.commands.switch_optimizer("ps")
        wait_until(lambda: app.session.optimizer_name == "ps", what="the switch to ps")
        assert app.session.system is clock
    finally:
        app.stop()
