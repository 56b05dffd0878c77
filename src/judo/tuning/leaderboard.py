"""`python -m judo leaderboard`: which optimizer wins on which task, each tuned with the same
budget, then scored on fresh seeds.

python -m judo leaderboard --tasks pendulum cartpole --optimizers ps mppi cem --trials 20 --seeds 10

For each task x optimizer, tune's machinery (one Optuna study per pair, its trials as Ray tasks:
study.py's `run_trials`) searches the optimizer's own settings for `--trials` trials, the first of
them its defaults, at the task's protocol (leaderboard_protocol.py: rate, latency, horizon, knots,
N, episode length, metric and sign) on the protocol's tuning seeds. The best trial is then validated
on `--seeds` fresh seeds (0, 1, ...), as is the shipped default (the app's optimizer with every
setting as shipped). The studies are in one SQLite file in --out and each finished validation in
validation.json, so Ctrl-C keeps all that finished and the same command resumes.
"""

import os
import shlex
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import tyro
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from judo.cli_shared import (
    apply_config_file,
    fail,
    name_listing,
    output_console,
    progress_display,
)
from judo.core.configuration.config import require
from judo.core.configuration.config_values import apply_values
from judo.core.configuration.registry import default_configs
from judo.core.errors import JudoError
from judo.tuning.best_file import write_best_toml
from judo.tuning.conditions import Condition
from judo.tuning.heartbeat import DEAD_PROCESS, failure_of
from judo.tuning.leaderboard_args import LeaderboardArgs
from judo.tuning.leaderboard_protocol import Protocol, load_protocol
from judo.tuning.leaderboard_report import SHIPPED_ENTRY, Cell
from judo.tuning.leaderboard_validation import Jobs, validate
from judo.tuning.objective import Objective, make_objective
from judo.tuning.space import Param, build_space
from judo.tuning.trial import TrialSpec

PROG = "python -m judo leaderboard"
DESCRIPTION = (
    "Rank optimizers per task: for each task x optimizer, tune the optimizer's own settings "
    "(tune's machinery: an "
    "Optuna study, trials as Ray tasks) with the same --trials budget at the task's protocol "
    "(rate, latency, "
    "horizon, knots, N, episode length, metric and its sign: "
    "judo/tuning/protocols/TASK.toml, or --protocols DIR) "
    "on its tuning seeds, then score the best settings and the shipped default on --seeds "
    "fresh seeds with 95% "
    "confidence intervals. Prints the table (a column per task, the winner bold) and writes "
    "to --out "
    "leaderboard.md, leaderboard.csv, leaderboard.png and configs/TASK-OPTIMIZER.toml (for "
    "--config). The studies "
    "live in --out/leaderboard.db: Ctrl-C keeps every finished trial and the same command "
    "resumes. Needs the "
    "`tune` extra: pip install -e '.[tune]'."
)
SHIPPED_OPTIMIZER = "mppi"
"""The optimizer the app runs when none is named (runtime/launch.py): the shipped default's."""
PROBE_S = 0.2
"""Seconds of sim time of the check episode run per task before any study, which also lists its
metrics."""
RESTARTED = ("interrupted", DEAD_PROCESS)
"""Failures that do not use up a trial of the budget: a Ctrl-C's, or a process that died."""


@dataclass
class Pair:
    """One task x optimizer: its protocol, search space, trial spec and Optuna study."""

    protocol: Protocol
    optimizer: str
    objective: Objective
    space: list[Param]
    spec: TrialSpec
    study: Any

    @property
    def task(self) -> str:
        """The task's name."""
        return self.protocol.task

    def target(self, trials: int) -> int:
        """Finished trials the study should have: `trials` (one with nothing to search) plus those a
        Ctrl-C or a dead process failed, which do not use up the budget."""
        restarted = sum(failure_of(trial) in RESTARTED for trial in self.study.trials)
        return (trials if self.space else 1) + restarted

    def done(self, trials: int) -> int:
        """Trials of the budget finished so far."""
        kept = [trial for trial in self.study.trials if trial.state.name in ("COMPLETE", "FAIL")]
        return min(
            trials if self.space else 1, sum(failure_of(trial) not in RESTARTED for trial in kept)
        )


def protocol_spec(
    protocol: Protocol, optimizer: str, config_file: str | None, fixed: dict[str, Any]
) -> TrialSpec:
    """The TrialSpec of `optimizer`'s trials at `protocol`: its tuning seeds, under one condition
    (rate, latency)."""
    return TrialSpec(
        protocol.task,
        optimizer,
        protocol.metric,
        protocol.tuning_seeds,
        protocol.duration,
        config_file=config_file,
        fixed=fixed,
        conditions=(Condition(protocol.control_freq, protocol.latency_ms),),
        maximize=protocol.direction == "maximize",
        first_seed=protocol.tuning_first_seed,
    )


def probe_metrics(protocol: Protocol, optimizer: str) -> list[str]:
    """The metrics a short episode of the task reports (tune's probe, at the protocol); JudoError if
    it fails."""
    from judo.tuning.tune import probe
    from judo.tuning.tune_args import TuneArgs

    args = TuneArgs(task=protocol.task, optimizer=optimizer, duration=PROBE_S)
    return probe(args, protocol.fixed())


def open_pairs(args: LeaderboardArgs, storage: str, console: Any) -> list[Pair]:
    """Every task x optimizer with its study created or loaded (the defaults queued as trial 0 of a
    new one)."""
    from judo.tuning import study as studies

    config_file = None if args.config is None else str(args.config.resolve())
    pairs = []
    for task in args.task_names():
        protocol = load_protocol(task, args.protocols)
        require(
            protocol.tuning_first_seed >= args.seeds,
            f"{protocol.path}: its tuning seeds (from tuning_first_seed = "
            f"{protocol.tuning_first_seed}) overlap the "
            f"validation seeds 0 to {args.seeds - 1}; give fewer --seeds or a "
            f"tuning_first_seed of {args.seeds} or more",
        )
        objective = make_objective(
            task, protocol.metric, probe_metrics(protocol, args.optimizer_names()[0])
        )
        objective = Objective(objective.metric, protocol.direction)
        for optimizer in args.optimizer_names():
            fixed = protocol.fixed()
            # ConfigError now if they do not fit
            configs = apply_values(default_configs(task, optimizer), fixed)
            space = build_space(task, optimizer, (), fixed)
            spec = protocol_spec(protocol, optimizer, config_file, fixed)
            sampler = studies.make_sampler(args.sampler, args.seed, space, False)
            identity = {
                "task": task,
                "optimizer": optimizer,
                "metric": protocol.metric,
                "protocol": protocol.line(),
            }
            name = f"{task}-{optimizer}-{protocol.digest()}"
            study, _, notes = studies.open_study(storage, name, objective, sampler, identity)
            if not study.trials:
                studies.enqueue_defaults(study, space, configs)
            for note in notes:
                console.print(f"resumed {name}: {note}")
            pairs.append(Pair(protocol, optimizer, objective, space, spec, study))
    return pairs


def tune_pairs(pairs: list[Pair], trials: int, capacity: int) -> None:
    """Run every pair's missing trials, pair after pair, under one progress bar over all trials with
    an ETA."""
    from judo.tuning import study as studies

    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    budgets = [trials if pair.space else 1 for pair in pairs]
    done = [pair.done(trials) for pair in pairs]
    with progress_display(*columns) as progress:
        bar = progress.add_task("trials", total=sum(budgets), completed=sum(done))
        for index, pair in enumerate(pairs):
            if done[index] >= budgets[index]:
                continue
            label = f"{pair.task} x {pair.optimizer}"
            progress.update(bar, description=label)

            def show(_: Any, index: int = index, pair: Pair = pair, label: str = label) -> None:
                done[index] += 1  # one more trial told (a Ctrl-C's are not)
                best = studies.best_trial(pair.study, pair.objective)
                score = "" if best is None else f", best {pair.objective.metric} {best.value:.4g}"
                progress.update(bar, completed=sum(done), description=label + score)

            studies.run_trials(
                pair.study, pair.space, pair.spec, pair.target(trials), capacity, None, show
            )


def validation_jobs(pairs: list[Pair], seeds: int, config_file: str | None) -> Jobs:
    """{key: (spec, values)} of everything to validate: each pair's best trial, and each task's
    shipped default.

    A key names what was run (task, entry, protocol digest, best trial, seeds), so a validation
    stored under it is reused on resume and redone when the best trial changed."""
    from judo.tuning import study as studies

    jobs: Jobs = {}
    for pair in pairs:
        best = studies.best_trial(pair.study, pair.objective)
        if best is not None:
            spec = replace(pair.spec, seeds=seeds, first_seed=0)
            jobs[
                f"{pair.task}|{pair.optimizer}|{pair.protocol.digest()}|trial "
                f"{best.number}|{seeds} seeds"
            ] = (
                spec,
                best.params,
            )
    for protocol in {pair.task: pair.protocol for pair in pairs}.values():
        spec = replace(
            protocol_spec(protocol, SHIPPED_OPTIMIZER, config_file, {}), seeds=seeds, first_seed=0
        )
        jobs[f"{protocol.task}|{SHIPPED_ENTRY}|{protocol.digest()}|{seeds} seeds"] = (spec, {})
    return jobs


def collect_cells(
    pairs: list[Pair], jobs: Jobs, store: dict, out: Path, command: str
) -> list[Cell]:
    """Every pair's cell and each task's shipped default, with the tuned configs written to
    out/configs/."""
    from judo.tuning import study as studies

    cells = []
    for pair in pairs:
        best = studies.best_trial(pair.study, pair.objective)
        baseline = studies.baseline_trial(pair.study)
        states = [trial.state.name for trial in pair.study.trials]
        cell = Cell(pair.task, pair.optimizer, pair.optimizer, trials=states.count("COMPLETE"))
        cell.failed_trials = states.count("FAIL")
        cell.defaults_value = None if baseline is None else baseline.value
        if best is None:
            failed = [failure_of(trial) for trial in pair.study.trials if failure_of(trial)]
            cell.failure = f"no completed trial ({failed[0]})" if failed else "no completed trial"
            cells.append(cell)
            continue
        cell.best_trial, cell.tuned_value, cell.params = best.number, best.value, dict(best.params)
        key = next(key for key in jobs if key.startswith(f"{pair.task}|{pair.optimizer}|"))
        fill(cell, store.get(key))
        cell.config = str(write_config(out, pair, best, cell, command))
        cells.append(cell)
    for key, (spec, _) in jobs.items():
        task, entry = key.split("|")[:2]
        if entry == SHIPPED_ENTRY:
            cells.append(
                fill(
                    Cell(task, f"{SHIPPED_ENTRY} ({spec.optimizer})", spec.optimizer),
                    store.get(key),
                )
            )
    return cells


def fill(cell: Cell, stored: dict | None) -> Cell:
    """`cell` with the validation stored for it (none: "not validated")."""
    if stored is not None:
        cell.scores, cell.plan_ms = list(stored["scores"]), stored["plan_ms"]
        cell.failure = cell.failure or stored["failure"]
    return cell


def write_config(out: Path, pair: Pair, best: Any, cell: Cell, command: str) -> Path:
    """configs/TASK-OPTIMIZER.toml: the protocol's settings and the best trial's, as a --config
    file."""
    path = out / "configs" / f"{pair.task}-{pair.optimizer}.toml"
    values = {
        **pair.spec.fixed,
        "controller.control_freq": pair.protocol.control_freq,
        **best.params,
    }
    header = [
        f"{pair.task} x {pair.optimizer}, tuned by a leaderboard: trial {best.number} of study "
        f"{pair.study.study_name!r}, {pair.objective.metric} = {best.value:.6g} on the "
        "tuning seeds; "
        f"{cell.text()} on {len(cell.scores)} fresh seeds.",
        f"Protocol ({pair.protocol.path}): {pair.protocol.line()}.",
        f"Found by: {command}",
        f"Use with: python -m judo --config {path}  (or evaluate --config ... --task ... "
        "--optimizer ...)",
    ]
    write_best_toml(path, pair.task, pair.optimizer, values, header)
    return path


def leaderboard(args: LeaderboardArgs, command: str) -> int:
    """Run (or resume) the leaderboard; returns the exit status (130 on Ctrl-C, 1 when no cell has a
    score)."""
    import judo.ray_cluster as cluster
    from judo.tuning import leaderboard_report as report
    from judo.tuning import study as studies

    studies.import_optuna()
    cluster.import_ray(PROG)
    apply_config_file(args.config)
    args.validate()
    console = output_console()
    args.out.mkdir(parents=True, exist_ok=True)
    storage = f"sqlite:///{args.out / 'leaderboard.db'}"
    pairs = open_pairs(args, storage, console)
    config_file = None if args.config is None else str(args.config.resolve())
    started, cpus, finished = time.perf_counter(), args.workers or os.cpu_count() or 1, False
    connected = cluster.start_ray(args.address, cpus)
    try:
        cpus = args.workers or cluster.cluster_cpus()
        tune_pairs(pairs, args.trials, cpus)
        jobs = validation_jobs(pairs, args.seeds, config_file)
        store = validate(jobs, args.out / "validation.json", args.address, cpus)
        finished = True
    except KeyboardInterrupt:
        print(
            f"interrupted: every finished trial is in {storage} and every finished validation in "
            f"{args.out / 'validation.json'}; run the same command to resume",
            file=sys.stderr,
        )
        return 130
    finally:
        if connected:
            cluster.stop_ray()
        runs = report.record_run(args.out, time.perf_counter() - started, cpus, finished)
    cells = collect_cells(pairs, jobs, store, args.out, command)
    protocols = {pair.task: pair.protocol for pair in pairs}
    notes = [f"Command: `{command}`", "", report.hours_line(runs) + "."]
    title = f"leaderboard: {args.trials} trials per pair, validated on {args.seeds} fresh seeds"
    table = report.rich_table(cells, protocols, title)
    table.caption = report.hours_line(runs)
    console.print(table)
    report.write_markdown(args.out / "leaderboard.md", cells, protocols, notes)
    report.write_csv(args.out / "leaderboard.csv", cells, protocols)
    plotted = report.write_plot(args.out / "leaderboard.png", cells, protocols, title)
    written = [
        "leaderboard.md",
        "leaderboard.csv",
        *(["leaderboard.png"] if plotted else []),
        "configs/*.toml",
    ]
    console.print(f"wrote {', '.join(str(args.out / name) for name in written)}")
    return 0 if any(cell.summary is not None for cell in cells) else 1


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo leaderboard` on `argv` (sys.argv[1:] when None); exits with status 2 on
    bad arguments."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = tyro.cli(
        LeaderboardArgs, args=argv, prog=PROG, description=DESCRIPTION + " " + name_listing()
    )
    try:
        return leaderboard(args, f"{PROG} {shlex.join(argv)}")
    except JudoError as err:
        fail(str(err))
