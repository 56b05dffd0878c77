"""The app with rehearsed sensing and an estimator: the plant it builds, the estimate it publishes,
the estimator config edits it takes, the names it refuses, and the GUI's ghost, panel and error
chart (no browser)."""

import mujoco
import numpy as np
import pytest

from judo.core.errors import ConfigError, JudoError, UnknownNameError
from judo.estimators.ekf import EKFConfig, ExtendedKalmanFilter
from judo.estimators.ukf import UnscentedKalmanFilter
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem
from judo.runtime.app import App
from judo.runtime.gui.plots import estimation_error
from judo.runtime.running.estimator_thread import EstimatorThread
from judo.tasks.cartpole import Cartpole

SENSING = {"observe": "sensors", "sensor_noise": 0.005, "sensor_delay": 0.01, "sensor_rate": 100}


def sensed_app(**kwargs) -> App:
    return App("cartpole", "mppi", gui=False, seed=0, num_workers=1, **{**SENSING, **kwargs})


def published(app: App, wait_until, count: int = 20):
    """The "system" snapshot once the plant has stepped a while and the planner has planned."""
    wait_until(lambda: app.stats.num_plans() >= 3, timeout=30, what="plans")
    start = app.buffer.latest("system").version
    wait_until(lambda: app.buffer.latest("system").version >= start + count, what="plant steps")
    return app.buffer.latest("system").value


def test_observing_sensors_builds_a_sensed_plant_and_the_ekf(wait_until):
    app = sensed_app()
    session = app.session
    assert isinstance(session.system, SensedSystem)
    assert (
        isinstance(session.simulated, MujocoSystem) and session.simulated is session.system.system
    )
    assert session.estimator_name == "ekf"
    assert isinstance(session.closed_loop.estimator, EstimatorThread)  # off the plant thread
    assert isinstance(session.closed_loop.estimator.estimator, ExtendedKalmanFilter)
    assert session.system.delay.tolist() == [0.01, 0.01] and session.system.period.tolist() == [
        0.01,
        0.01,
    ]
    app.start()
    try:
        snapshot = published(app, wait_until)
        assert snapshot.true_state is not None and snapshot.true_state.shape == (4,)
        assert snapshot.reading.state is not None  # the estimate the plan starts from
        # noisy, late readings
        assert not np.array_equal(snapshot.reading.state, snapshot.true_state)
        position, velocity = estimation_error(
            session.controller.task.model, snapshot.true_state, snapshot.reading.state
        )
        assert position < 0.1 and velocity < 1.0  # the filter tracks the cart and pole
    finally:
        app.stop()


def test_full_state_runs_no_estimator_and_publishes_no_truth(wait_until):
    app = App("cartpole", "mppi", gui=False, seed=0, num_workers=1)
    assert (
        isinstance(app.session.system, MujocoSystem) and app.session.closed_loop.estimator is None
    )
    with pytest.raises(JudoError, match="no estimator runs"):
        app.commands.update_estimator_config({"noise_jointpos": 0.01})
    app.start()
    try:
        assert published(app, wait_until, count=5).true_state is None
    finally:
        app.stop()


def test_a_named_estimator_and_its_config_are_used_and_one_that_cannot_read_the_plant_refused():
    config = EKFConfig(noise_jointpos=0.02)
    app = sensed_app(estimator="ekf", estimator_config=config)
    assert app.session.closed_loop.estimator.config is config
    app = App("cartpole", gui=False, seed=0, num_workers=1, estimator="state")  # the pass-through
    assert app.session.estimator_name == "state" and isinstance(app.session.system, MujocoSystem)
    with pytest.raises(
        ConfigError,
        match="the 'ekf' estimator cannot run on this plant's readings: .*observe='sensors'",
    ):
        # a full-state plant has no sensor readings to fuse
        App("cartpole", gui=False, estimator="ekf")
    with pytest.raises(
        ConfigError, match="the 'state' estimator cannot run on this plant's readings"
    ):
        sensed_app(estimator="state")


def test_a_users_sensors_only_system_gets_the_ekf_by_default():
    plant = SensedSystem(
        MujocoSystem.from_task(Cartpole(), seed=0), noise=0.005, rng=np.random.default_rng(0)
    )
    app = App("cartpole", gui=False, seed=0, num_workers=1, system=plant)
    assert app.session.estimator_name == "ekf" and app.session.system is plant
    with pytest.raises(ConfigError, match="your System chooses what it measures"):
        App("cartpole", gui=False, system=plant, observe="sensors")


def test_estimator_config_edits_are_applied_and_bad_ones_refused(wait_until):
    app = sensed_app()
    estimator = app.session.closed_loop.estimator
    edits: list = []
    app.on_config_change(lambda kind, config, from_gui: edits.append((kind, config, from_gui)))
    updated = app.commands.update_estimator_config({"noise_jointpos": 0.02, "relinearize_every": 3})
    assert (
        estimator.config is updated
        and updated.noise_jointpos == 0.02
        and updated.relinearize_every == 3
    )
    assert edits == [("estimator", updated, False)]
    with pytest.raises(ConfigError, match="must be positive"):
        app.commands.update_estimator_config({"noise_jointpos": -1.0})
    with pytest.raises(JudoError, match="no_such_field"):
        app.commands.update_estimator_config({"no_such_field": 1.0})
    with pytest.raises(ConfigError, match="changed since this edit"):
        app.commands.update_estimator_config(
            {"noise_jointpos": 0.03}, generation=app.session.generation + 1
        )
    assert estimator.config.noise_jointpos == 0.02


def test_bad_names_and_settings_are_refused_at_once():
    with pytest.raises(
        UnknownNameError,
        match="unknown estimator 'nope'; valid estimators are: ekf, legged, state, ukf",
    ):
        App("cartpole", gui=False, estimator="nope")
    with pytest.raises(ConfigError, match="observe must be one of"):
        App("cartpole", gui=False, observe="camera")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="sensor rate must be above 0 Hz"):
        sensed_app(sensor_rate=0)
    with pytest.raises(ConfigError, match="estimator_config for 'state' must be a"):
        App("cartpole", gui=False, estimator="state", estimator_config=EKFConfig())


def test_switches_keep_the_sensing_and_the_live_estimator_config(wait_until):
    app = sensed_app()
    app.commands.update_estimator_config({"noise_jointpos": 0.02})
    app.start()
    try:
        app.commands.switch_optimizer("cem")
        wait_until(
            lambda: app.session.optimizer_name == "cem", timeout=30, what="the optimizer switch"
        )
        assert isinstance(app.session.system, SensedSystem)
        assert app.session.closed_loop.estimator.config.noise_jointpos == 0.02
        app.commands.switch_task("acrobot")
        wait_until(lambda: app.session.task_name == "acrobot", timeout=30, what="the task switch")
        session = app.session
        assert isinstance(session.system, SensedSystem) and session.system.delay.tolist() == [
            0.01,
            0.01,
        ]
        assert isinstance(session.closed_loop.estimator.estimator, ExtendedKalmanFilter)
    finally:
        app.stop()


def test_switching_the_estimator_rebuilds_the_session_on_the_running_plant(wait_until):
    app = App("cartpole", "mppi", gui=False, seed=0, num_workers=1)
    with pytest.raises(UnknownNameError, match="valid estimators are: ekf, legged, state, ukf"):
        app.commands.switch_estimator("nope")
    with pytest.raises(
        ConfigError, match="the 'ekf' estimator cannot run on this plant's readings"
    ):
        app.commands.switch_estimator("ekf")
    app.start()
    try:
        plant = app.session.system
        app.commands.switch_estimator("state")
        wait_until(
            lambda: app.session.estimator_name == "state", timeout=30, what="the estimator switch"
        )
        assert app.session.system is plant and app.session.generation == 1
        assert app.status.message.startswith(
            "switched to cartpole with mppi and the state estimator"
        )
        app.commands.switch_estimator(None)
        wait_until(
            lambda: app.session.closed_loop.estimator is None,
            timeout=30,
            what="the estimator removed",
        )
    finally:
        app.stop()
    sensed = sensed_app()
    sensed.session.closed_loop.read()
    with pytest.raises(JudoError, match="cannot plan without an estimator"):
        sensed.commands.switch_estimator(None)
    with pytest.raises(ConfigError, match="the 'state' estimator cannot run"):
        sensed.commands.switch_estimator("state")
    sensed.start()
    try:
        sensed.commands.update_estimator_config({"noise_jointpos": 0.02})
        sensed.commands.switch_estimator("ekf")  # the one running: restarted, its tuned config kept
        wait_until(lambda: sensed.session.generation == 1, timeout=30, what="the estimator switch")
        assert sensed.session.closed_loop.estimator.config.noise_jointpos == 0.02
    finally:
        sensed.stop()


def test_the_gui_draws_the_estimate_as_a_ghost_with_its_panel_and_error_chart(port, wait_until):
    app = App("cartpole", "mppi", port=port, seed=0, num_workers=1, **SENSING)
    app.start()
    try:
        gui = app.gui
        wait_until(
            lambda: gui.shown_generation == app.session.generation and gui.ghost is not None,
            what="the GUI",
        )
        assert (
            gui.estimator_panel is not None and "noise_jointpos" in gui.estimator_panel.field_names
        )
        # the pole's ghost
        assert gui.server.scene.get_handle_by_name("/ghost/body_2/geom_3") is not None
        model = app.session.controller.task.model
        data = mujoco.MjData(model)

        def ghost_follows_estimate() -> bool:
            snapshot = app.buffer.latest("system").value
            data.qpos[:] = snapshot.reading.state[: model.nq]
            mujoco.mj_kinematics(model, data)
            ghost_ok = np.allclose(gui.ghost.body_frames[2].wxyz, data.xquat[2], atol=0.05)
            data.qpos[:] = snapshot.true_state[: model.nq]
            mujoco.mj_kinematics(model, data)
            return ghost_ok and np.allclose(gui.scene.body_frames[2].wxyz, data.xquat[2], atol=0.05)

        wait_until(
            ghost_follows_estimate, what="the ghost to follow the estimate and the robot the truth"
        )
        wait_until(
            lambda: len(gui.plots.estimation.data[0]) >= 3,
            what="points on the estimation-error chart",
        )
        gui.estimator_panel._on_edit({"noise_jointpos": 0.03})  # what a slider's edit calls
        assert app.session.closed_loop.estimator.config.noise_jointpos == 0.03
        assert gui.controls.estimator.value == "ekf"
    finally:
        app.stop()


def test_the_app_runs_the_ukf_tracks_the_plant_and_takes_its_spread_edits(wait_until):
    app = sensed_app(estimator="ukf")
    estimator = app.session.closed_loop.estimator
    assert isinstance(estimator.estimator, UnscentedKalmanFilter)
    assert estimator.config.process_noise_velocity == 0.02  # cartpole's TOML section for the ukf
    with pytest.raises(JudoError, match="relinearize_every"):
        # the EKF's field, not the UKF's
        app.commands.update_estimator_config({"relinearize_every": 3})
    assert app.commands.update_estimator_config({"spread": 0.5}).spread == 0.5
    app.start()
    try:
        snapshot = published(app, wait_until)
        position, velocity = estimation_error(
            app.session.controller.task.model, snapshot.true_state, snapshot.reading.state
        )
        assert position < 0.1 and velocity < 1.0  # the sigma points track the cart and pole
    finally:
        app.stop()
