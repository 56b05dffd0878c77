"""One syntax on every command line: a boolean is --NAME / --no-NAME in the app and in every command
that takes config fields (benchmark, evaluate, collect), and a model override MuJoCo cannot simulate
is a one-line exit 2 before anything runs, in the app, evaluate, tune, collect, plant and excite
alike."""

from pathlib import Path

import pytest

from judo.__main__ import main
from judo.cli_shared import parse_args, parse_args_with_config_fields
from judo.collection.collect import CollectArgs
from judo.core.configuration.registry import default_configs
from judo.evaluation.benchmark import BenchmarkArgs
from judo.evaluation.evaluate import EvaluateArgs
from judo.runtime.launch import parse


def parsed_controllers(flags: list[str]) -> dict[str, object]:
    """command -> the controller config (or overrides) its parser makes of `--task cartpole` and
    `flags`."""
    argv = ["--task", "cartpole", "--optimizer", "mppi", *flags]
    _, configs = parse(argv, dict(default_configs("cartpole", "mppi")))
    return {
        "app": configs["controller"],
        "benchmark": parse_args(
            BenchmarkArgs, ["--tasks", "cartpole", *flags], "benchmark", ""
        ).controller,
        "evaluate": parse_args_with_config_fields(EvaluateArgs, argv, "evaluate", "").controller,
        "collect": parse_args_with_config_fields(
            CollectArgs, [*argv, "--out", "x.h5"], "collect", ""
        ).controller,
    }


@pytest.mark.parametrize(
    "flag, value", [("--controller.feedback", True), ("--controller.no-feedback", False)]
)
def test_every_command_takes_the_apps_boolean_flags(flag, value):
    for command, controller in parsed_controllers(
        [flag, "--controller.no-latency-compensation"]
    ).items():
        assert (controller.feedback, controller.latency_compensation) == (value, False), command  # type: ignore[attr-defined]
    assert all(
        # a command's None: the task's
        controller.feedback is (False if command == "app" else None)  # type: ignore[attr-defined]
        for command, controller in parsed_controllers([]).items()
    )


def test_an_optimizer_configs_boolean_is_a_flag_too():
    argv = ["--task", "cartpole", "--optimizer", "mppi", "--optimizer-config.no-use-noise-ramp"]
    assert (
        parse_args_with_config_fields(
            EvaluateArgs, argv, "evaluate", ""
        ).optimizer_config.use_noise_ramp
        is False
    )


def test_the_old_value_form_is_refused_in_one_syntax(capsys):
    argv = ["--task", "cartpole", "--optimizer", "mppi", "--controller.feedback", "True"]
    with pytest.raises(SystemExit) as caught:
        parse_args_with_config_fields(EvaluateArgs, argv, "evaluate", "")
    assert caught.value.code == 2 and "True" in capsys.readouterr().err


TIMESTEP_MESSAGE = "opt.timestep must be above 0 for MuJoCo to simulate it, got 0"


def exit_status(argv: list[str]) -> int | None:
    """`python -m judo ARGV`'s exit status, whether its command returns it or exits with it."""
    try:
        return main(argv)
    except SystemExit as exit:
        return exit.code if isinstance(exit.code, int) else 1


@pytest.mark.parametrize(
    "command, extra",
    [
        ("app", ["--task", "cartpole", "--headless", "--duration", "2"]),
        (
            "evaluate",
            ["--task", "cartpole", "--optimizer", "ps", "--seeds", "1", "--duration", "1"],
        ),
        (
            "collect",
            [
                "--task",
                "cartpole",
                "--optimizer",
                "ps",
                "--episodes",
                "1",
                "--duration",
                "1",
                "--out",
                "OUT",
            ],
        ),
        (
            "tune",
            [
                "--task",
                "cartpole",
                "--optimizer",
                "ps",
                "--trials",
                "1",
                "--duration",
                "1",
                "--out",
                "OUT",
            ],
        ),
        ("plant", ["--task", "cartpole", "--duration", "1"]),
        ("excite", ["--task", "cartpole", "--duration", "1", "--out", "OUT"]),
    ],
)
def test_a_timestep_mujoco_cannot_step_is_a_one_line_exit_2_before_anything_runs(
    command, extra, tmp_path, capsys
):
    out = tmp_path / ("out.h5" if command in ("collect", "excite") else "out")
    argv = [
        *([] if command == "app" else [command]),
        *[str(out) if a == "OUT" else a for a in extra],
    ]
    if command in ("tune", "collect", "excite"):
        pytest.importorskip({"tune": "optuna", "collect": "h5py", "excite": "h5py"}[command])
    assert exit_status([*argv, "--plant-overrides", "opt.timestep=0"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.endswith(TIMESTEP_MESSAGE), err
    assert not out.exists()  # nothing was written: the check came first


@pytest.mark.parametrize(
    "system, message",
    [
        (
            "judo.loop.system:System",
            "--system judo.loop.system:System: expected a System subclass that "
            "writes every method, got System, which "
            "leaves apply, read_state, reset, step abstract "
            "(judo.loop.system:MujocoSystem is judo's simulator)",
        ),
        (
            "judo.loop.system:DynamicsSystem",
            "--system judo.loop.system:DynamicsSystem: DynamicsSystem needs a task "
            "that is a DynamicsTask, got Cartpole",
        ),
        (
            "judo.core.configuration.registry:set_model_overrides",
            "--system judo.core.configuration.registry:set_model_overrides: expected "
            "a System subclass 'set_model_overrides' in "
            "judo.core.configuration.registry, got function",
        ),
    ],
)
def test_a_system_judo_cannot_build_is_a_one_line_exit_2(system, message, capsys):
    assert (
        exit_status(["--task", "cartpole", "--headless", "--duration", "1", "--system", system])
        == 2
    )
    assert capsys.readouterr().err.strip() == f"python -m judo: {message}"


@pytest.mark.skipif(
    not Path("/proc/self").is_dir(), reason="needs Linux's /proc, where no file can be made"
)
@pytest.mark.parametrize(
    "argv",
    [
        [
            "evaluate",
            "--task",
            "cartpole",
            "--optimizer",
            "ps",
            "--seeds",
            "1",
            "--json",
            "/proc/nope/x.json",
        ],
        ["tune", "--task", "cartpole", "--optimizer", "ps", "--trials", "1", "--out", "/proc/nope"],
    ],
)
def test_an_output_where_nothing_can_be_made_is_a_one_line_exit_2_even_for_root(argv, capsys):
    """os.access lets root write anywhere, /proc included; the check makes a real file where the
    output would go."""
    if argv[0] == "tune":
        pytest.importorskip("optuna")
    assert exit_status(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"error: {argv[-2]}: cannot write in '/proc' ("), err
