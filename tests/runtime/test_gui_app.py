"""The Gui of a running App, without a browser: it follows switches, resets and the plant."""

import dataclasses
import time
from pathlib import Path

import numpy as np
import pytest
import viser

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import make_config
from judo.runtime.app import App


def shows_session(app: App) -> bool:
    """True once the GUI has built its panels and scene for the session in use."""
    return app.gui.shown_generation == app.session.generation


def test_panels_hold_the_fields_of_the_running_configs(app, wait_until):
    wait_until(lambda: shows_session(app), what="the GUI to build")
    panels = app.gui.panels
    assert panels["controller"].field_names == [
        "horizon",
        "spline_order",
        "control_freq",
        "max_opt_iters",
        "iterations_per_second",
        "max_num_traces",
        "num_randomizations",
        "risk",
        "cvar_alpha",
        "risk_scale",
        "redraw_every",
        "max_plan_age",
        "latency_compensation",
        "feedback",
    ]  # no policy_samples: without a proposal policy every value but 0 would be refused
    # its left end is a short age, not the watchdog off
    age = panels["controller"].handles("max_plan_age")[0]
    assert (age.min, age.max, age.value) == (0.05, 5.0, 0.5)
    assert panels["optimizer"].field_names == [
        "num_rollouts",
        "num_nodes",
        "use_noise_ramp",
        "noise_ramp",
        "sigma",
        "temperature",
    ]
    assert panels["task"].field_names == ["w_vertical", "w_centered", "w_velocity", "w_control"]
    assert app.gui.controls.task.value == "cartpole" and app.gui.controls.optimizer.value == "mppi"
    assert app.gui.url == f"http://127.0.0.1:{app.port}"


def test_the_scene_follows_the_plant_and_draws_traces(app, wait_until):
    wait_until(lambda: shows_session(app) and app.stats.num_plans() > 2, what="plans")
    cart = app.gui.scene.body_frames[1]
    wait_until(
        lambda: np.allclose(
            cart.position[0], app.buffer.latest("system").value.reading.state[0], atol=0.05
        ),
        what="the cart frame to follow the plant",
    )
    wait_until(
        lambda: app.gui.server.scene.get_handle_by_name("/traces/nominal") is not None,
        what="traces",
    )


def test_reset_configs_refreshes_the_widgets(app, wait_until):
    wait_until(lambda: shows_session(app), what="the GUI to build")
    app.commands.update_config("controller", {"horizon": 2.0})
    wait_until(
        lambda: app.gui.panels["controller"].value_of("horizon") == 2.0,
        what="the widget to show 2.0",
    )
    # Paused, nothing plans: no late cycle at horizon 2.0 on a loaded machine reports over the
    # reset's status
    # (the pause cancels a cycle in flight, whose report comes once it ends: wait for that too).
    app.commands.pause()
    wait_until(lambda: app._state.cycle is None, what="the cycle in flight to end")
    app.commands.reset_configs()
    default = make_config(ControllerConfig, "cartpole").horizon
    wait_until(
        lambda: app.gui.panels["controller"].value_of("horizon") == default,
        what=f"the widget to show {default}",
    )
    # The status line is set just after the configs, so a GUI frame may fall in between: wait for it
    # too.
    wait_until(
        lambda: "configs reset to the defaults" in app.gui.controls.status.content,
        what="the status line",
    )
    app.commands.resume()


def test_an_optimizer_switch_keeps_the_scene_and_a_task_switch_replaces_it(app, wait_until):
    wait_until(lambda: shows_session(app), what="the GUI to build")
    scene = app.gui.scene
    app.commands.switch_optimizer("ps")
    wait_until(
        lambda: app.session.optimizer_name == "ps" and shows_session(app), what="the ps panel"
    )
    assert app.gui.scene is scene and app.gui.controls.optimizer.value == "ps"
    assert "temperature" not in app.gui.panels["optimizer"].field_names
    app.commands.switch_task("cylinder_push")
    wait_until(
        lambda: app.session.task_name == "cylinder_push" and shows_session(app), what="a new scene"
    )
    assert app.gui.scene is not scene
    assert app.gui.controls.task.value == "cylinder_push"
    assert app.gui.panels["task"].field_names[-1] == "goal_pos"
    marker = app.gui.server.scene.get_handle_by_name("/markers/goal")
    assert isinstance(marker, viser.IcosphereHandle)
    app.commands.update_config("task", {"goal_pos": [0.4, -0.3]})
    wait_until(
        lambda: np.allclose(marker.position, [0.4, -0.3, 0.0]), what="the goal marker to move"
    )


def test_a_taken_port_moves_the_gui_to_the_next_free_one(app):
    second = App("cartpole", "mppi", host="127.0.0.1", port=app.port, num_workers=1)
    second.start()
    try:
        assert second.gui.url != app.gui.url and second.gui.server.get_port() > app.port
    finally:
        second.stop()


def test_the_record_box_follows_recordings_and_leaves_a_pages_toggle_alone_until_it_is_acted_on(
    app, wait_until, tmp_path
):
    """viser applies a page's toggle, then runs its callback on its thread pool: the GUI loop (30
    Hz) must not put the box back meanwhile, or the callback reads the box put back (an untick under
    load started a second recording)."""
    pytest.importorskip("h5py")
    wait_until(lambda: shows_session(app), what="the GUI to build")
    record = app.gui.controls.record

    def record_a_few_steps(path) -> None:
        app.start_recording(path)
        steps = app.stats.num_plans()
        wait_until(lambda: app.stats.num_plans() >= steps + 2, what="two plans recorded")

    record_a_few_steps(tmp_path / "a.h5")
    wait_until(lambda: record.value, what="the box to tick when a recording starts")
    # where a page's untick leaves the box until its callback runs (set here, no callback runs)
    record.value = False
    time.sleep(0.5)  # about 15 GUI updates
    assert record.value is False, (
        "the GUI loop put the box back before the page's untick was acted on"
    )
    app.stop_recording()
    record.value = True  # a stale tick: the next recording change is shown over it
    record_a_few_steps(tmp_path / "b.h5")
    app.stop_recording()
    wait_until(lambda: not record.value, what="the box to untick when a recording ends")


def test_a_plan_made_before_a_reset_never_draws_its_traces_over_the_reset_plant(app, wait_until):
    def nominal_trace():
        return app.gui.server.scene.get_handle_by_name("/traces/nominal")

    wait_until(lambda: shows_session(app) and nominal_trace() is not None, what="traces")
    app.commands.pause()
    stale = app.buffer.latest("plan").value  # planned from the plant before the reset
    resets = app.resets_done
    app.commands.reset_task()
    wait_until(
        lambda: app.resets_done == resets + 1 and nominal_trace() is None,
        what="the reset to clear the traces",
    )
    # as a cycle still in flight at the reset, or not yet drawn, would publish it
    app.buffer.publish("plan", stale)
    time.sleep(0.5)  # many GUI updates
    assert nominal_trace() is None and app.paused
    # planned after the reset
    app.buffer.publish("plan", dataclasses.replace(stale, resets=app.resets_done))
    wait_until(lambda: nominal_trace() is not None, what="a plan made after the reset drawn")


POLICY = Path(judo.__file__).parent / "tasks" / "models" / "policies" / "pendulum_chunk.onnx"


def test_a_policy_session_shows_only_the_fields_a_policy_uses_and_proposals_their_slider(
    port, wait_until
):
    pytest.importorskip("onnxruntime")
    app = App(
        "pendulum", "ps", port=port, seed=0, num_workers=1, policy=POLICY, proposal_policy=POLICY
    )
    app.start()
    try:
        wait_until(lambda: shows_session(app), what="the GUI to build")
        assert app.gui.panels["controller"].field_names == list(POLICY_USES_FIELDS_IN_ORDER)
        # MPC with the policy's proposals: every field, policy_samples among them
        app.commands.switch_optimizer("ps")
        wait_until(
            lambda: shows_session(app) and app.session.optimizer_name == "ps", what="the switch"
        )
        names = app.gui.panels["controller"].field_names
        assert names[-1] == "policy_samples" and len(names) == len(
            dataclasses.fields(ControllerConfig)
        )
        samples = app.gui.panels["controller"].handles("policy_samples")[0]
        assert (samples.min, samples.max, samples.value) == (0, 64, 0)
    finally:
        app.stop()


POLICY_USES_FIELDS_IN_ORDER = (
    "horizon",
    "spline_order",
    "control_freq",
    "max_plan_age",
    "latency_compensation",
)


def test_quadruped_velocity_shows_the_command_it_tracks(port, wait_until):
    app = App("quadruped_velocity", "ps", port=port, seed=0, num_workers=1)
    app.start()
    try:
        wait_until(
            lambda: shows_session(app) and app.gui.controls.task_readout.content,
            what="the task's readout",
        )
        command = app.buffer.latest("system").value.reading.metadata["velocity_command"]
        shown = app.gui.controls.task_readout.content
        assert shown.startswith("command: forward ") and shown.endswith(" rad/s"), shown
        # a command redrawn meanwhile
        assert f"turn {command[2]:.2f} rad/s" in shown or app.stats.sim_time() > 2.0
    finally:
        app.stop()
    assert judo.get_registered_tasks()["cartpole"][0]().readout({}) is None  # the default: no line
