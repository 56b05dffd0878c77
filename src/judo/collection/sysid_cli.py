"""`python -m judo sysid`: fit planning-model parameters to logs and write them as a --config file (docs/sysid.md).

python -m judo sysid run.h5 --task cartpole --params body_mass.pole dof_damping.slider --out fitted.toml
python -m judo evaluate --task cartpole --optimizer mppi --config fitted.toml     # plan with the fitted model
"""

import json
import math
import shlex
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import tyro

from judo.cli_shared import apply_config_file, fail, output_console, parse_args, progress_console
from judo.core.boundary import check_output_file, require
from judo.core.errors import JudoError

DESCRIPTION = (
    "Fit named parameters of a task's planning model (MjModel fields by element name, as [model_overrides] sets "
    "them) to logged episodes with MuJoCo's system identification (mujoco.sysid): each episode is cut into windows "
    "rolled out from their logged start states under the logged actions, and the parameters minimise the "
    "difference to the logged states. Writes --out, a --config file whose [model_overrides.TASK] section holds the "
    "parameters the data determine, and a report beside it (OUT.md): each parameter before and after with its 95% "
    "confidence interval, the fit's conditioning, and the prediction error before and after. A parameter the data "
    "do not excite is reported and left out. Needs the `sysid` extra, and `collect` for HDF5 logs or `ros2` for the "
    "bridge's MCAP logs: pip install -e '.[sysid]'."
)


@dataclass
class SysidArgs:
    """The logs, the task, the parameters and where the fit goes."""

    logs: tyro.conf.Positional[tuple[Path, ...]]
    """Logs to fit: collect's HDF5 files, the GUI's recordings or the ROS 2 bridge's MCAP logs (--record) of --task."""
    task: Annotated[str, tyro.conf.arg(metavar="NAME")] = field(kw_only=True)
    """The task whose planning model is fitted, by registered name."""
    params: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT")] = field(kw_only=True)
    """Parameters to fit: MjModel fields by element name, e.g. body_mass.pole dof_damping.slider, or one entry of
    a row, geom_friction.cube[0]."""
    out: Annotated[Path, tyro.conf.arg(metavar="FITTED.toml")] = field(kw_only=True)
    """The --config file to write; the report goes beside it (FITTED.md)."""
    config: Annotated[Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")] = None
    """TOML file that registers a custom task (copied into --out) or whose [model_overrides] the fit starts from."""
    window: float = 0.05
    """Seconds of each window rolled out from a logged state (the prediction horizon fitted). Short windows keep
    the residual smooth through contacts (leap_cube fits its friction over 0.05 s and misses it over 0.1 s);
    longer ones average noisy measurements on smooth systems."""
    max_iters: int = 50
    """Most iterations of mujoco.sysid's least-squares optimizer."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for an argument that is wrong, before anything is read or written."""
        require(len(self.logs) > 0, "give at least one log file: python -m judo sysid LOG.h5 ... --task T ...")
        require(self.out.suffix == ".toml", f"--out must name a .toml file, got {str(self.out)!r}")
        require(math.isfinite(self.window) and self.window > 0, f"--window must be > 0 seconds, got {self.window}")
        require(self.max_iters >= 1, f"--max-iters must be at least 1, got {self.max_iters}")
        check_output_file("--out", self.out)


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo sysid` on `argv` (sys.argv[1:] when None); exits with status 2 on bad arguments and
    bad logs, having written nothing."""
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
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from judo.collection.sysid import fit, parse_parameters, read_logs
    from judo.core.registry import make_task

    task = make_task(args.task)
    parameters = parse_parameters(args.params, task.model)
    episodes = read_logs(list(args.logs), args.task, task.model)
    steps = max(1, round(args.window / float(task.model.opt.timestep)))
    columns = (SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn())
    with Progress(*columns, console=progress_console(), transient=True) as progress:
        bar = progress.add_task(f"fitting {len(parameters)} parameters", total=None)

        def on_evaluation(count: int) -> None:
            progress.update(bar, description=f"fitting {len(parameters)} parameters: {count} residual evaluations")

        result = fit(task, parameters, episodes, steps, args.max_iters, on_evaluation)
    header = [command, f"fitted to {result.num_windows} windows of {steps} steps from {len(episodes)} episode(s)"]
    text = fitted_toml(args.task, result.overrides(task.model), header, _custom_tables(args.config))
    report = report_text(args, result, command, len(episodes))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    report_path = args.out.with_suffix(".md")
    report_path.write_text(report)
    console = output_console()
    console.print(report, markup=False, highlight=False)
    console.print(f"wrote {args.out} and {report_path}")


def _custom_tables(config: Path | None) -> dict[str, Any]:
    """The [custom_tasks] and [custom_optimizers] of the --config file, so --out registers the same task."""
    if config is None:
        return {}
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    table = tomllib.loads(config.read_text())
    return {key: table[key] for key in ("custom_tasks", "custom_optimizers") if key in table}


def fitted_toml(task: str, overrides: dict[str, dict[str, Any]], header: list[str], custom: dict[str, Any]) -> str:
    """The --config file of the fit: `header` as comments, `custom` tables, then [model_overrides.TASK]."""
    from judo.core.model_overrides import toml_value

    lines = [f"# {line}" for line in header]
    for section, entries in custom.items():
        for name, entry in entries.items():
            lines += ["", f"[{section}.{name}]"] + [f"{key} = {json.dumps(value)}" for key, value in entry.items()]
    lines += ["", f"[model_overrides.{task}]"]
    for field_name, values in overrides.items():
        for element, value in values.items():
            written = toml_value(value)
            literal_value = repr(written) if isinstance(written, float) else "[" + ", ".join(map(repr, written)) + "]"
            lines.append(f"{field_name}.{_key(element)} = {literal_value}")
    if not overrides:
        lines.append("# no parameter was determined by the data; see the report")
    return "\n".join(lines) + "\n"


def _key(name: str) -> str:
    """An element name as a TOML key: bare where it can be, else quoted."""
    return name if name.replace("_", "").replace("-", "").isalnum() else '"' + name.replace('"', '\\"') + '"'


def report_text(args: SysidArgs, result: Any, command: str, num_episodes: int) -> str:
    """The fit's report as Markdown: the parameters before and after, the conditioning and the prediction error."""
    lines = [
        f"# sysid: {args.task}",
        "",
        f"`{command}`",
        "",
        f"{num_episodes} episode(s) from {', '.join(str(p) for p in args.logs)}: {result.num_windows} windows of "
        f"{result.window_steps} steps ({args.window:g} s); fit in {result.seconds:.1f} s.",
        "",
        "| parameter | planning model | fitted | 95% interval | determined by the data |",
        "|---|---|---|---|---|",
    ]
    for parameter, before, after, half, excited in zip(
        result.parameters, result.planning, result.fitted, result.interval, result.excited, strict=True
    ):
        interval = f"± {half:.3g}" if math.isfinite(half) else "unbounded"
        verdict = "yes" if excited else "no: not excited by the data, left out of --out"
        lines.append(f"| {parameter.name} | {before:.6g} | {after:.6g} | {interval} | {verdict} |")
    lines += [
        "",
        f"Conditioning: cond(J) = {result.condition:.3g} (the residual's Jacobian at the fit, each column scaled by its "
        "parameter's value; above about 1e6 the data cannot tell the parameters apart).",
        "",
        f"{result.window_steps}-step prediction error (RMS, each state coordinate over its spread in the log): "
        f"{result.error_before:.4g} on the planning model, {result.error_after:.4g} on the fitted one.",
    ]
    missing = [p.name for p, excited in zip(result.parameters, result.excited, strict=True) if not excited]
    if missing:
        lines += [
            "",
            f"Not determined: {', '.join(missing)}. Their confidence intervals exceed 25% of the value: the logged "
            "motion hardly depends on them. Log motion that does (python -m judo excite), or fit fewer parameters.",
        ]
    return "\n".join(lines) + "\n"
