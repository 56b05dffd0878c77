"""The app's --safety.* flags (the same fields and checks as evaluate's) and the GUI's read-only
list of the limits."""

import concurrent.futures

import pytest
import viser

from judo.core.configuration.registry import default_configs, make_config, make_task
from judo.runtime import launch
from judo.runtime.gui.safety_panel import SafetyPanel, limit_lines
from judo.safety.config import SafetyConfig
from judo.safety.limits import resolve

CARTPOLE = ["--task", "cartpole", "--optimizer", "ps"]


def test_the_apps_safety_flags_become_the_tasks_limits_over_its_defaults():
    before = make_config(SafetyConfig, "cartpole")
    argv = [
        *CARTPOLE,
        "--safety.position",
        "slider=-0.3:0.3",
        "--safety.velocity",
        "slider=1.5",
        "--safety.joint-ranges",
    ]
    options, _ = launch.parse(argv, default_configs("cartpole", "ps"), safety=before)
    given = launch.changed_fields(before, options.safety)
    assert given == {
        "joint_ranges": True,
        "position": ("slider=-0.3:0.3",),
        "velocity": ("slider=1.5",),
    }
    launch.set_task_limits("cartpole", given)
    # what every session of the task is built with
    assert make_config(SafetyConfig, "cartpole") == options.safety
    # another task keeps its own
    assert make_config(SafetyConfig, "cylinder_push") == SafetyConfig()


def test_no_safety_flag_changes_nothing():
    before = make_config(SafetyConfig, "cartpole")
    options, _ = launch.parse(CARTPOLE, default_configs("cartpole", "ps"), safety=before)
    assert launch.changed_fields(before, options.safety) == {}
    assert not make_config(SafetyConfig, "cartpole").active


def test_a_limit_the_model_lacks_is_a_one_line_error_before_the_app_starts(capsys):
    assert (
        launch.main(
            [*CARTPOLE, "--safety.position", "slidr=-0.3:0.3", "--headless", "--duration", "0.1"]
        )
        == 2
    )
    assert capsys.readouterr().err.strip() == (
        "python -m judo: safety limits: unknown hinge or slide joint 'slidr'; valid hinge or "
        "slide joints are: "
        "slider, hinge"
    )


def test_the_gui_lists_each_limit_in_force_read_only():
    config = SafetyConfig(
        position=("slider=-0.3:0.3",),
        velocity=("slider=1.5",),
        effort=("push=0.8",),
        rate=("push=20",),
    )
    lines = limit_lines(resolve(make_task("cartpole"), config))
    assert lines == [
        "position slider: -0.3 to 0.3",
        "velocity slider: |qvel| <= 1.5",
        "effort push: |force| <= 0.8",
        "rate push: units/s <= 20",
    ]
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        panel = SafetyPanel(server.gui, resolve(make_task("cartpole"), config), order=45)
        assert panel.markdown.content == "\n".join(f"- `{line}`" for line in lines)
        panel.remove()
        none = SafetyPanel(server.gui, None, order=45)
        assert none.markdown.content == "No limits set ([safety.TASK], --safety.*)."
        none.remove()
    finally:
        server.stop()


@pytest.mark.slow
def test_the_headless_app_serves_under_the_flags_limits(capsys):
    argv = [
        *CARTPOLE,
        "--headless",
        "--duration",
        "0.3",
        "--seed",
        "0",
        "--safety.position",
        "slider=-0.3:0.3",
    ]
    argv += ["--safety.velocity", "slider=1.5"]
    # On its own thread: a browser test earlier in the run may hold an event loop on the main
    # thread, and the app runs its own with asyncio.run.
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        assert pool.submit(launch.main, argv).result(timeout=300) == 0
    out = capsys.readouterr().out
    assert "limits" in out and "safety:" in out and "commands filtered" in out


def test_evaluate_sets_its_flags_through_the_same_function_and_refuses_them_on_ray():
    from judo.core.errors import ConfigError
    from judo.evaluation.evaluate import EvaluateArgs, SafetyOverrides, apply_safety_flags

    apply_safety_flags(
        EvaluateArgs(
            task="cartpole", optimizer="ps", safety=SafetyOverrides(velocity=("slider=1.5",))
        )
    )
    assert make_config(SafetyConfig, "cartpole").velocity == ("slider=1.5",)
    on_ray = EvaluateArgs(
        task="cartpole", optimizer="ps", workers=2, safety=SafetyOverrides(rate=("push=20",))
    )
    with pytest.raises(
        ConfigError,
        match=r"^--safety\.\* sets limits in "
        r"this process only; with --workers",
    ):
        apply_safety_flags(on_ray)
