"""`python -m judo`: run a task and optimizer in real time, with the browser GUI or headless.

The options are built by tyro from the same dataclasses the GUI shows, for the task and optimizer
named on the command line:

    python -m judo --task cartpole --optimizer mppi --controller.horizon 0.8 --optimizer-config.sigma 0.2
    python -m judo --task cylinder_push --headless --duration 10
    python -m judo --task cartpole --optimizer cem --help     # lists the cem and cartpole fields
    python -m judo --config judo.toml                          # custom classes and overrides from a file
    python -m judo --task leap_cube --observe sensors --sensor-rate-hz 100 --sensor-rate-hz framepos=30 \
        --sensor-delay-ms framepos=40 --estimator ekf --estimator-config.noise-framepos 0.003

Precedence, lowest first: the dataclass defaults, the task's registered overrides, the config file,
the command-line options, then live GUI edits.
"""  # noqa: E501

import argparse
import dataclasses
import logging
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import tyro
import tyro.constructors

from judo.cli_shared import merge_repeated
from judo.core.commandline.boundary import MAX_DURATION
from judo.core.configuration.config import Config, ConfigT, with_updates
from judo.core.configuration.config_file import LoadedConfig, load_config
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.model_overrides import parse_override_entries
from judo.core.configuration.registry import (
    CONFIG_GROUPS,
    default_configs,
    get_registered_optimizers,
    get_registered_tasks,
    lookup_estimator,
    lookup_task,
    make_config,
    set_model_overrides,
)
from judo.core.errors import ConfigError, JudoError
from judo.core.estimator import EstimatorConfig, estimator_in_force
from judo.core.optimizer import OptimizerConfig
from judo.core.rollouts.backend import RolloutBackendName
from judo.core.task import TaskConfig
from judo.evaluation.sensing import SensingFlags
from judo.ros2.options import Ros2Options, UnitreeOptions, ros2_options, unitree_options
from judo.runtime.app import App
from judo.safety.config import SafetyConfig
from judo.safety.limits import set_task_limits
from judo.system_choice import SystemOptions, build_system

PROG = "python -m judo"


@dataclass
class RunOptions:
    """What to run and how to serve it, and how the simulated plant is observed (`sensing`, flags
    without a prefix)."""

    config: Path | None = None
    """TOML file that registers custom tasks and optimizers and sets per-task overrides (see
    docs/configuration.md)."""
    task: str = "cartpole"
    """Registered task to run (the config file's `task` when it names one)."""
    optimizer: str = "mppi"
    """Registered optimizer to plan with (the config file's `optimizer` when it names one)."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant only, by element name (a plant unlike the planning
    model, to rehearse on), e.g. body_mass.pole=0.13; after the --config file's
    [plant_overrides.TASK] (docs/sysid.md)."""
    host: str = "127.0.0.1"
    """Address the GUI listens on: this machine only by default. 0.0.0.0 (every interface) exposes
    the app to the network, behind a token; prefer an SSH tunnel (docs/gui.md)."""
    port: int = 8080
    """Port of the GUI server, 0..65535 (the next free one if it is taken)."""
    token: str | None = None
    """Secret the GUI's URL must carry (http://HOST:PORT/TOKEN); generated when --host is not a
    loopback address."""
    share: bool = False
    """Show viser's share button, which opens a public URL (share.viser.studio) to this GUI for
    anyone who has it."""
    headless: bool = False
    """Run the same loops without the GUI (for scripts and CI)."""
    duration: float | None = None
    """Stop after this many seconds of sim time and print a summary; by default run until Ctrl-C."""
    seed: int | None = None
    """Seed of the optimizer, the task and the simulated plant."""
    backend: RolloutBackendName = "cpu"
    """Rollout backend: cpu (a thread per core) or warp (MuJoCo Warp on the GPU; needs pip install
    -e ".[warp]")."""
    policy: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.onnx", help_behavior_hint="(optional)")
    ] = None
    """A policy (an ONNX file, run on onnxruntime) that drives the plant instead of --optimizer,
    through the same closed loop (docs/policies.md); its metadata's control_freq, horizon and
    spline_order are the defaults of --controller.*. The GUI's optimizer dropdown switches to MPC
    (--optimizer's configs) and back to "policy"."""
    proposal_policy: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.onnx", help_behavior_hint="(optional)")
    ] = None
    """Policy whose candidates replace --controller.policy-samples of the optimizer's num_rollouts
    each update (the policy as a proposal, docs/policies.md; the GUI's policy_samples slider sets
    how many)."""
    system: str | None = None
    """The plant: judo's simulator by default (sim); ros2, a robot on a ROS 2 graph over DDS (needs
    pip install -e ".[ros2]"; docs/hardware.md); or module:Class, a user's System subclass built
    with Class(task)."""
    record: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.mcap", help_behavior_hint="(optional)")
    ] = None
    """With --system ros2: log what the robot sent and what judo commanded to this MCAP file, with
    ROS 2 schemas."""
    stop_file: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.json", help_behavior_hint="(optional)")
    ] = None
    """The latched stop's state file (docs/safety.md): while it exists the app starts stopped; by
    default $JUDO_STOP_FILE, else ~/.local/state/judo/stop.json."""
    ros2: tyro.conf.Suppress[Ros2Options] = field(default_factory=Ros2Options)
    """The ROS 2 bridge's domain, topics, rate and joint names (--ros2.*, a group of its own)."""
    unitree: tyro.conf.Suppress[UnitreeOptions] = field(default_factory=UnitreeOptions)
    """The Unitree bridge's robot, domain, interface, rate and soft start (--unitree.*, a group of
    its own)."""
    safety: tyro.conf.Suppress[SafetyConfig] = field(default_factory=SafetyConfig)
    """The owner's limits of --task (--safety.*, a group of its own; docs/safety.md), over its
    [safety.TASK]."""
    sensing: Annotated[SensingFlags, tyro.conf.OmitArgPrefixes, tyro.conf.arg(name="")] = field(
        default_factory=SensingFlags
    )
    """--observe, --sensor-*, --estimator."""


def main(argv: Sequence[str] | None = None) -> int:
    """Parse `argv` (default: sys.argv[1:]), run the app, and return the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        task, optimizer, loaded, estimator, pinned = _peek(argv)
        ros2 = ros2_options(loaded.ros2 if loaded is not None else {}, "the config file's [ros2]")
        unitree = unitree_options(
            loaded.unitree if loaded is not None else {}, "the config file's [unitree]"
        )
        # the estimator may join the three kinds
        defaults: dict[str, Config] = {**default_configs(task, optimizer)}
        if estimator is not None:
            defaults["estimator"] = make_config(lookup_estimator(estimator)[1], task)
    except JudoError as err:  # an unknown name, or a config file that cannot be applied
        print(f"{PROG}: {err}", file=sys.stderr)
        return 2
    argv = ["--task", task, "--optimizer", optimizer, *merge_repeated(argv)]
    try:
        safety = make_config(SafetyConfig, task)  # the task's and the --config file's [safety.TASK]
        options, configs = parse(argv, defaults, ros2, unitree, safety)
        # what --safety.* changed
        set_task_limits(options.task, changed_fields(safety, options.safety))
        if (
            options.duration is not None
            and math.isfinite(options.duration)
            and options.duration > MAX_DURATION
        ):
            raise ConfigError(  # its step count would not fit an integer
                "duration must be a positive, finite number of seconds of sim time, "
                f"at most {MAX_DURATION:g}, got {options.duration}"
            )
        controller_config = _as_kind(configs["controller"], ControllerConfig)
        if options.policy is not None and controller_config == defaults["controller"]:
            # no --controller.* given: the policy's metadata's rate and chunk layout
            controller_config = None
        task_config = _as_kind(configs["task"], TaskConfig)
        # the flag wins
        system_name = options.system or (loaded.system if loaded is not None else None)
        system = build_system(
            SystemOptions(system_name, options.record, options.ros2, options.unitree),
            options.task,
            task_config,
        )
        app = App(
            options.task,
            options.optimizer,
            controller_config=controller_config,
            optimizer_config=_as_kind(configs["optimizer"], OptimizerConfig),
            task_config=task_config,
            system=system,
            gui=not options.headless,
            host=options.host,
            port=options.port,
            token=options.token,
            share=options.share,
            duration=options.duration,
            seed=options.seed,
            backend=options.backend,
            observe=options.sensing.observe,
            proposal_policy=options.proposal_policy,
            policy=options.policy,
            stop_file=options.stop_file,
            # None: each task's own default, at start and on a switch
            estimator=estimator if pinned else None,
            estimator_config=_as_kind(configs.get("estimator"), EstimatorConfig)
            if pinned
            else None,
            **{f"sensor_{key}": value for key, value in options.sensing.sensor_settings().items()},
        )
    except JudoError as err:
        print(f"{PROG}: {err}", file=sys.stderr)
        return 2
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    print(f"{PROG}: {options.task} with {options.optimizer}; Ctrl-C stops", file=sys.stderr)
    try:
        summary = app.run()
    except JudoError as err:  # the GUI could not start
        print(f"{PROG}: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C before the app's own handler was in place
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    finally:
        # a robot link: its last command acknowledged, its log finished
        close = getattr(system, "close", None)
        if callable(close):
            close()
    print(summary)
    if options.headless and summary.num_plans == 0:
        why = app.status.message if app.status.level != "info" else "no planning cycle completed"
        print(f"{PROG}: no plan ever succeeded in this run: {why}", file=sys.stderr)
        return 1
    return 0


def parse(
    argv: list[str],
    defaults: dict[str, Any],
    ros2: Ros2Options | None = None,
    unitree: UnitreeOptions | None = None,
    safety: SafetyConfig | None = None,
) -> tuple[RunOptions, dict[str, Config]]:
    """The run options and the validated controller, optimizer and task configs from `argv` (the
    --ros2.* options over `ros2`'s values, the --safety.* ones over `safety`'s).

    Raises ConfigError for a value the configs refuse (e.g. a wrong-length array).
    """
    groups = [
        (CONFIG_GROUPS[kind], type(config), field(default_factory=lambda config=config: config))
        for kind, config in defaults.items()
    ]
    # RunOptions' flags without a prefix
    flat = Annotated[RunOptions, tyro.conf.OmitArgPrefixes, tyro.conf.arg(name="")]
    options_field = ("options", flat, field(default_factory=RunOptions))
    ros2_field = (
        "ros2",
        Ros2Options,
        field(default_factory=lambda: ros2 or Ros2Options()),
    )  # --ros2.domain-id, ... (with --system ros2)
    unitree_field = (
        "unitree",
        UnitreeOptions,
        field(default_factory=lambda: unitree or UnitreeOptions()),
    )
    safety_field = ("safety", SafetyConfig, field(default_factory=lambda: safety or SafetyConfig()))
    arguments_cls = dataclasses.make_dataclass(
        "JudoArguments", [options_field, ros2_field, unitree_field, safety_field, *groups]
    )
    parsed = tyro.cli(
        arguments_cls,
        args=argv,
        prog=PROG,
        description=_description(),
        registry=_registry(),
    )
    configs = {}
    for kind, config in defaults.items():
        given = getattr(parsed, CONFIG_GROUPS[kind])
        configs[kind] = with_updates(
            config, {f.name: getattr(given, f.name) for f in fields(given)}
        )
    options = dataclasses.replace(
        parsed.options, ros2=parsed.ros2, unitree=parsed.unitree, safety=parsed.safety
    )
    return options, configs


def changed_fields(before: Config, after: Config) -> dict[str, Any]:
    """{field: value} of `after` that differ from `before` (the fields a command line changed in a
    group)."""
    return {
        f.name: getattr(after, f.name)
        for f in fields(after)
        if getattr(after, f.name) != getattr(before, f.name)
    }


def _as_kind(config: Config | None, cls: type[ConfigT]) -> ConfigT | None:
    """`config` typed as the base class of its kind (`parse` keeps each default's class:
    `default_configs` and `make_config` build the controller's, the optimizer's, the task's and the
    estimator's); None stays None."""
    assert config is None or isinstance(config, cls), (
        f"expected a {cls.__name__}, got {type(config).__name__}"
    )
    return config


def _peek(argv: list[str]) -> tuple[str, str, LoadedConfig | None, str | None, bool]:
    """What tyro's options depend on, read in one pass before tyro builds them: (task, optimizer,
    the loaded --config file or None, the estimator to run, whether it is pinned).

    Loads the --config file first (registering its classes and overrides), whose names stand in for
    --task and --optimizer when those are not given; applies --plant-overrides. The estimator, whose
    config fields become --estimator-config.* options, is --estimator's, else the task's default
    with --observe sensors (`estimator_in_force`), else None; it is pinned (kept across task
    switches, with the config given) when --estimator or an --estimator-config.* field names it,
    else each task runs its own default. Raises JudoError for a bad file, UnknownNameError for an
    unknown task.
    """
    peek = argparse.ArgumentParser(prog=PROG, add_help=False)
    for flag in ("--config", "--task", "--optimizer", "--estimator", "--observe"):
        peek.add_argument(flag, default=None)
    peek.add_argument("--plant-overrides", "--plant_overrides", nargs="*", default=())
    known, rest = peek.parse_known_args(argv)
    loaded = load_config(known.config) if known.config is not None else None
    task = known.task or (loaded and loaded.task) or RunOptions.task
    optimizer = known.optimizer or (loaded and loaded.optimizer) or RunOptions.optimizer
    if known.plant_overrides:
        set_model_overrides(task, parse_override_entries(known.plant_overrides), plant=True)
    fields_given = any(
        arg.startswith(("--estimator-config.", "--estimator_config.")) for arg in rest
    )
    estimator = estimator_in_force(known.observe or "state", known.estimator, lookup_task(task)[0])
    return task, optimizer, loaded, estimator, known.estimator is not None or fields_given


def _description() -> str:
    tasks = ", ".join(sorted(get_registered_tasks()))
    optimizers = ", ".join(sorted(get_registered_optimizers()))
    return (
        "Run sampling-based MPC on a MuJoCo task in real time, with a browser GUI (or --headless). "
        "The controller, optimizer and task options below belong to the chosen --task and "
        "--optimizer; "
        f"pass those first to see their fields. Tasks: {tasks}. Optimizers: {optimizers}. "
        f"Also: `{PROG} benchmark ...`, `{PROG} evaluate ...`, `{PROG} tune ...`, `{PROG} "
        "leaderboard --tasks ...`, "
        f"`{PROG} collect ...`, "
        f"`{PROG} replay FILE.h5`, `{PROG} distill DATA.h5 --out POLICY.onnx`, `{PROG} "
        "gait-search --out "
        f"POLICY.onnx`, `{PROG} plant --task T` (judo's simulator as a ROS 2 robot process), "
        f"`{PROG} excite --task T "
        f"--out LOG.h5` (a log worth fitting) and `{PROG} sysid LOG.h5 --task T --params ... "
        "--out FITTED.toml` (each "
        "with --help)."
    )


def _registry() -> tyro.constructors.ConstructorRegistry:
    """tyro rules for the types configs use beyond tyro's own: 1-D numpy arrays as lists of
    floats."""
    registry = tyro.constructors.ConstructorRegistry()

    @registry.primitive_rule
    def _array(
        type_info: tyro.constructors.PrimitiveTypeInfo,
    ) -> tyro.constructors.PrimitiveConstructorSpec | None:
        if type_info.type is not np.ndarray:
            return None
        return tyro.constructors.PrimitiveConstructorSpec(
            nargs="*",
            metavar="FLOAT [FLOAT ...]",
            instance_from_str=lambda args: np.array([float(a) for a in args]),
            is_instance=lambda value: isinstance(value, np.ndarray),
            str_from_instance=lambda value: [repr(float(x)) for x in value],
        )

    return registry
