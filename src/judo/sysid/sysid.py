"""`python -m judo sysid`: fit planning-model parameters to logs and write them as a --config file
(docs/sysid.md).

python -m judo sysid run.h5 --task cartpole --params body_mass.pole dof_damping.slider --out fitted.toml
python -m judo evaluate --task cartpole --optimizer mppi --config fitted.toml     # plan with the fitted model
"""  # noqa: E501

import math
import shlex
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import tyro

from judo.cli_shared import apply_config_file, fail, output_console, parse_args, progress_display
from judo.core.commandline.boundary import check_output_file
from judo.core.configuration.config import require
from judo.core.errors import JudoError

DESCRIPTION = (
    "Fit named parameters of a task's planning model (MjModel fields by element name, as "
    "[model_overrides] sets "
    "them) to logged episodes with MuJoCo's system identification (mujoco.sysid): each "
    "episode is cut into windows "
    "rolled out from their logged start states under the logged actions, and the parameters "
    "minimise the "
    "difference to the logged states, or, for a log whose plant reported only its measured "
    "sensors (--observe "
    "sensors, a robot's encoders), to the measured sensors, each window starting from the "
    "logged estimate. Writes --out, a --config file whose [model_overrides.TASK] section "
    "holds the "
    "parameters the data determine, and a report beside it (OUT.md): each parameter before "
    "and after with its 95% "
    "confidence interval, the fit's conditioning, and the prediction error before and after. "
    "A parameter the data "
    "do not excite is reported and left out, and so is every parameter of a fit that "
    "explains little of the log "
    "(the report names what is likely missing). Whole steps of command delay are tried "
    "(--command-delay), and every "
    "fifth window is held out and its error reported. --fit-delay also fits how late the "
    "logged actions take "
    "effect in seconds. Needs the `sysid` extra, and `collect` for HDF5 logs or `ros2` for the "
    "bridge's MCAP logs: pip install -e '.[sysid]'."
)


DEFAULT_WINDOW = {"states": 0.05, "sensors": 0.5}
"""Seconds of a window when --window is not given, by what the fit compares."""
MAX_GIVEN_DELAY = 100
"""Most steps of command delay --command-delay may give."""


@dataclass
class SysidArgs:
    """The logs, the task, the parameters and where the fit goes."""

    logs: tyro.conf.Positional[tuple[Path, ...]]
    """Logs to fit: collect's HDF5 files, the GUI's recordings or the ROS 2 bridge's MCAP logs
    (--record) of --task."""
    task: Annotated[str, tyro.conf.arg(metavar="NAME")] = field(kw_only=True)
    """The task whose planning model is fitted, by registered name."""
    params: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT")] = field(kw_only=True)
    """Parameters to fit: MjModel fields by element name, e.g. body_mass.pole dof_damping.slider,
    and one entry of a longer row by its index, geom_friction.cube[0] or body_inertia.pole[1]."""
    out: Annotated[Path, tyro.conf.arg(metavar="FITTED.toml")] = field(kw_only=True)
    """The --config file to write; the report goes beside it (FITTED.md)."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file of the run: its custom task, settings and [model_overrides] (the fit starts from
    them); --out carries it over with the fitted parameters in its [model_overrides.TASK]."""
    window: Annotated[
        float | None,
        tyro.conf.arg(
            metavar="SECONDS",
            help_behavior_hint="(default: 0.05 comparing states, 0.5 comparing sensors)",
        ),
    ] = None
    """Seconds of each window rolled out from a logged state (the prediction horizon fitted). Short
    windows keep the residual smooth through contacts (leap_cube fits its friction over 0.05 s and
    misses it over 0.1 s); longer ones average noisy measurements and estimated start states (a
    pole's mass from noisy encoders: within 4% over 0.5 s, not determined over 0.2 s)."""
    max_iters: int = 50
    """Most iterations of mujoco.sysid's least-squares optimizer."""
    fit_delay: bool = False
    """Also fit the actuation delay (s, 0 to 0.1): how late each logged action takes effect, the
    same for every actuator. Reported with the parameters; written as actuator_delay where the
    planning model keeps the action history MuJoCo's delay needs (MJCF nsample), else as a comment
    saying what to add."""
    command_delay: Annotated[str, tyro.conf.arg(metavar="{auto,STEPS}")] = "auto"
    """Whole model steps each logged action reached the plant late (a bridge under load applies some
    commands a step after they were sent). auto: fit the parameters with each delay from 0 to 3
    steps and keep the one that predicts the log best (reported). Without --fit-delay only."""
    compare: Literal["auto", "states", "sensors"] = "auto"
    """What the predictions are compared with: the logged plant states, or the task's measured
    sensors as the plant reported them (noisy, late or slow: each value at the step it was taken),
    each window then starting from the logged estimate where there is one. auto: the sensors where
    every log holds them (an --observe sensors run, a System that reports no state), else the
    states."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for an argument that is wrong, before anything is read or
        written."""
        require(
            len(self.logs) > 0,
            "give at least one log file: python -m judo sysid LOG.h5 ... --task T ...",
        )
        require(self.out.suffix == ".toml", f"--out must name a .toml file, got {str(self.out)!r}")
        require(
            self.window is None or (math.isfinite(self.window) and self.window > 0),
            f"--window must be > 0 seconds, got {self.window}",
        )
        require(self.max_iters >= 1, f"--max-iters must be at least 1, got {self.max_iters}")
        require(
            self.command_delay == "auto"
            or (self.command_delay.isdigit() and int(self.command_delay) <= MAX_GIVEN_DELAY),
            "--command-delay takes auto or a whole number of steps from 0 to "
            f"{MAX_GIVEN_DELAY}, got "
            f"{self.command_delay!r}",
        )
        require(
            self.command_delay in ("auto", "0") or not self.fit_delay,
            f"--command-delay {self.command_delay} and --fit-delay both delay the actions; "
            "give one",
        )
        # the fitted file and the report beside it
        for path in (self.out, self.out.with_suffix(".md")):
            check_output_file("--out", path)


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo sysid` on `argv` (sys.argv[1:] when None); exits with status 2 on bad
    arguments and bad logs, having written nothing."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(SysidArgs, argv, "python -m judo sysid", DESCRIPTION)
    command = "python -m judo sysid " + shlex.join(argv)
    try:
        args.validate()
        apply_config_file(args.config)
        from judo.core.errors import import_extra

        if any(path.suffix.lower() != ".mcap" for path in args.logs):
            import_extra("h5py", "python -m judo sysid", "collect")
        else:
            import_extra("mcap_ros2.decoder", "python -m judo sysid LOG.mcap", "ros2")
        import_extra("scipy", "python -m judo sysid", "sysid")
        import_extra("colorama", "python -m judo sysid", "sysid")
        run(args, command)
    except JudoError as err:
        fail(str(err))
    return 0


def run(args: SysidArgs, command: str) -> None:
    """Read the logs, fit, and write --out and its report."""
    from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

    from judo.core.configuration.registry import make_task
    from judo.sysid.data import commands_line, compared, read_logs
    from judo.sysid.fit import fit
    from judo.sysid.fitted_toml import command_delay_note, delay_note, fitted_toml
    from judo.sysid.parameters import DELAY_PARAMETER, parse_parameters

    task = make_task(args.task)
    parameters = parse_parameters(args.params, task.model) + (
        [DELAY_PARAMETER] if args.fit_delay else []
    )
    episodes = read_logs(list(args.logs), args.task, task.model)
    compare = compared(episodes, args.compare)
    window = args.window if args.window is not None else DEFAULT_WINDOW[compare]
    steps = max(1, round(window / float(task.model.opt.timestep)))
    columns = (SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn())
    with progress_display(*columns) as progress:
        bar = progress.add_task(f"fitting {len(parameters)} parameters", total=None)

        def on_evaluation(count: int) -> None:
            progress.update(
                bar,
                description=f"fitting {len(parameters)} parameters: {count} residual evaluations",
            )

        delay = None if args.command_delay == "auto" else int(args.command_delay)
        result = fit(
            task, parameters, episodes, steps, args.max_iters, on_evaluation, compare, delay
        )
    header = [
        command,
        f"fitted to {result.num_windows} windows of {steps} steps from {len(episodes)} episode(s)",
    ]
    notes = delay_note(result, task.model) + command_delay_note(result)
    text = fitted_toml(
        args.task, result.overrides(task.model), header, _config_tables(args.config), notes
    )
    report = report_text(args, result, command, len(episodes), commands_line(episodes))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    report_path = args.out.with_suffix(".md")
    report_path.write_text(report)
    console = output_console()
    console.print(report, markup=False, highlight=False)
    console.print(f"wrote {args.out} and {report_path}")


def _config_tables(config: Path | None) -> dict[str, Any]:
    """The --config file's table (empty without one): --out carries it over, so that `--config
    FITTED.toml` plans as `--config CONFIG` did (the same custom tasks, controller, optimizer and
    plant settings) but for the fitted parameters."""
    if config is None:
        return {}
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    return tomllib.loads(config.read_text())


def compared_line(result: Any) -> str:
    """The report's one line on what the fit compared: the logged states, or the measured sensors
    and where each window started."""
    if result.compare == "states":
        return "Compared: the logged plant states, each window from the logged state."
    start = "the logged estimate" if result.from_estimate else "the logged state"
    return (
        "Compared: the measured sensors (their sensordata, at the step each value was taken), "
        f"each window from {start}."
    )


def report_text(
    args: SysidArgs, result: Any, command: str, num_episodes: int, commands: str = ""
) -> str:
    """The fit's report as Markdown: the parameters before and after, the command delay, the
    conditioning, the prediction error on the windows fitted and on those held out, and whether the
    fit explains the log; `commands`, the line on which commands the steps were paired with, after
    what it compared."""
    held = f", {result.num_held_out} more held out" if result.num_held_out else ""
    lines = [
        f"# sysid: {args.task}",
        "",
        f"`{command}`",
        "",
        f"{num_episodes} episode(s) from {', '.join(str(p) for p in args.logs)}: "
        f"{result.num_windows} windows of "
        f"{result.window_steps} steps ({result.window_steps * result.timestep:g} s) "
        f"fitted{held}; fit in "
        f"{result.seconds:.1f} s.",
        "",
        compared_line(result),
        "",
        *([commands, ""] if commands else []),
        "| parameter | planning model | fitted | 95% interval | determined by the data |",
        "|---|---|---|---|---|",
    ]
    for parameter, before, after, half, excited in zip(
        result.parameters,
        result.planning,
        result.fitted,
        result.interval,
        result.excited,
        strict=True,
    ):
        interval = f"± {half:.3g}" if math.isfinite(half) else "unbounded"
        if not excited:
            verdict = "no: not excited by the data, left out of --out"
        else:
            verdict = (
                "yes"
                if result.explains_log
                else ("no: the fit explains little of the log (below), left out")
            )
        name = f"{parameter.name} (s)" if parameter.field == "delay" else parameter.name
        name += " (a factor on its whole row)" if parameter.whole else ""
        lines.append(f"| {name} | {before:.6g} | {after:.6g} | {interval} | {verdict} |")
    quantity = "measured value" if result.compare == "sensors" else "state coordinate"
    lines += [
        "",
        command_delay_line(args, result),
        "",
        f"Conditioning: cond(J) = {result.condition:.3g} (the residual's Jacobian at the "
        "fit, each column scaled by its "
        "parameter's value; above about 1e6 the data cannot tell the parameters apart).",
        "",
        f"{result.window_steps}-step prediction error (RMS, each {quantity} over its spread "
        "in the log) on the windows "
        f"fitted: {result.error_before:.4g} on the planning model, {result.error_after:.4g} "
        "on the fitted one: the "
        f"fit removed {100 * result.removed:.1f}% of it."
        + (
            f" On the windows held out: {result.held_out_before:.4g} and "
            f"{result.held_out_after:.4g}."
            if result.num_held_out
            else " No window held out (fewer than 5)."
        ),
        f"Measurement noise alone would leave about {result.noise:.3g} (the residuals' "
        "scatter from step to step).",
    ]
    if not result.explains_log:
        missing = ", ".join(f"{name} ({100 * share:.0f}%)" for name, share in result.likely_missing)
        lines += [
            "",
            "**Not determined: the fit explains little of the log.** It removed "
            f"{100 * result.removed:.1f}% of the "
            f"prediction error, and what is left ({result.error_after:.3g}) is not the noise "
            f"({result.noise:.3g}): "
            "the model lacks something the fitted parameters cannot stand in for, so their "
            "intervals do not hold and "
            "--out gets none of them. "
            + (
                "Likely missing (the share of what is left each would remove, to first "
                f"order): {missing}; add "
                "them to --params."
                if missing
                else "No body's mass, inertia or centre of mass, nor any joint's damping or "
                "armature, explains it "
                "alone: look for commands applied at varying delays (a bridge under "
                "load), contacts or a part the "
                "model lacks."
            ),
        ]
    missing = [
        p.name for p, excited in zip(result.parameters, result.excited, strict=True) if not excited
    ]
    if missing:
        lines += [
            "",
            f"Not excited: {', '.join(missing)}. Their confidence intervals exceed 25% of "
            "the value: the logged "
            "motion hardly depends on them. Log motion that does (python -m judo excite), or "
            "fit fewer parameters.",
        ]
    return "\n".join(lines) + "\n"


def command_delay_line(args: SysidArgs, result: Any) -> str:
    """The report's line on the command delay: given, or chosen among those tried with their
    errors."""
    steps = result.command_delay
    said = f"Command delay: {steps} step{'' if steps == 1 else 's'} ({steps * result.timestep:g} s)"
    if args.command_delay != "auto":
        return f"{said}, as given (--command-delay {args.command_delay})."
    if args.fit_delay:
        return f"{said}: not tried, --fit-delay fits the delay in seconds."
    tried = ", ".join(f"{d}: {error:.4g}" for d, error in result.delay_errors.items())
    applied = (
        "in the step it was served"
        if steps == 0
        else (f"{steps} step{'' if steps == 1 else 's'} later")
    )
    return (
        f"{said}: each logged action applied {applied}, the delay whose fitted model "
        "predicts the windows best "
        f"(fitted error by steps of delay: {tried})."
    )
