"""`python -m judo tune`: search a task x optimizer's settings for the best closed-loop metric.

python -m judo tune --task leap_cube --optimizer mppi --metric goals_per_minute --trials 60 --seeds 3 --duration 20
"""  # noqa: E501

import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import tyro
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn

from judo.cli_shared import (
    apply_config_file,
    fail,
    merge_repeated,
    name_listing,
    output_console,
    progress_display,
    seeds_label,
)
from judo.core.commandline.boundary import (
    MAX_EPISODE,
    MAX_SAMPLES,
    MAX_WORKERS,
    check_count,
    check_output_folder,
)
from judo.core.configuration.config import require, require_between
from judo.core.configuration.config_values import apply_values
from judo.core.configuration.registry import default_configs, make_task
from judo.core.errors import JudoError
from judo.evaluation.plot import write_episode_plot
from judo.evaluation.sensing import Sensing
from judo.tuning.best_file import write_best_toml
from judo.tuning.heartbeat import dead_trial_notes, failure_of
from judo.tuning.objective import Objective, make_objective
from judo.tuning.space import Param, build_space, parse_fixed
from judo.tuning.trial import TrialSpec, run_seeded_episodes
from judo.tuning.tune_args import TuneArgs

DESCRIPTION = (
    "Tune a task x optimizer: search the optimizer's settings (every numeric field with a "
    "slider range, plus "
    "controller.horizon, each from 1/3 to 3 times its value in force; or --params) for the "
    "best value of one "
    "of the task's evaluate metrics, averaged over seeded closed-loop episodes under several "
    "conditions "
    "(--conditions; by default the task's check set: 20 Hz (or the task's minimum rate) and "
    "its own rate, crossed with no latency "
    "and 25 ms, 50 ms for the LEAP and fr3 tasks), aggregated by --aggregate. Optuna chooses "
    "the trials (TPE "
    "by default); each episode (a condition x a seed) runs as a Ray task on one core, on a "
    "local Ray or a "
    "cluster (--address). The study is stored in a database (SQLite by default), so the same "
    "command resumes "
    "it. Writes to --out: trials.csv, plots (PNG and HTML), summary.json, and best.toml, which "
    "`python -m judo --config` and `evaluate --config` read. With --observe sensors "
    "(--sensor-*, --estimator) "
    "every episode plans from the task's measured sensors through the estimator. Needs the "
    "`tune` extra: pip install -e '.[tune]'."
)
PROBE_DURATION = 0.2
"""Seconds of sim time of the check episode run before the study, which also lists the task's
metrics."""


def probe(args: TuneArgs, fixed: dict[str, Any]) -> list[str]:
    """Run one short episode with the default settings (and --fix) and return the metrics it
    reports.

    Raises JudoError when that episode fails, so a broken task stops the tune before Ray starts.
    """
    duration = min(PROBE_DURATION, args.duration)
    spec = TrialSpec(
        args.task, args.optimizer, "mean_reward", 1, duration, fixed=fixed, sensing=args.sensing()
    )
    try:
        (result,) = run_seeded_episodes(spec, {}, range(1))
    except JudoError:
        raise
    except Exception as err:  # a user's task may raise anything
        raise JudoError(
            f"a {spec.duration:g} s check episode of {args.task} x {args.optimizer} with the "
            "default settings failed: "
            f"{type(err).__name__}: {err}"
        ) from None
    return list(result.metrics)


def aggregate_text(spec: TrialSpec) -> str:
    """E.g. "worst" or "cvar 0.5": how a study aggregates its conditions."""
    return f"cvar {spec.cvar_alpha:g}" if spec.aggregate == "cvar" else spec.aggregate


def progress_text(objective: Objective, best: float | None) -> str:
    """The progress bar's description."""
    return f"best {objective.metric}: " + ("-" if best is None else f"{best:.4g}")


def tune(args: TuneArgs, command: str = "python -m judo tune") -> int:
    """Run the study described by `args`; returns the exit status. `command` is recorded in
    best.toml."""
    import judo.ray_cluster as cluster
    from judo.tuning import study as studies

    studies.import_optuna()  # the `tune` extra, checked before any work
    cluster.import_ray()
    apply_config_file(args.config)
    args.validate()
    if args.plant_overrides:  # checked now against the plant, in one line
        from judo.core.configuration.model_override_checks import check_model_overrides
        from judo.core.configuration.model_overrides import parse_override_entries

        check_model_overrides(
            make_task(args.task).sim_model, parse_override_entries(args.plant_overrides)
        )
    configs = default_configs(args.task, args.optimizer)
    fixed = parse_fixed(args.fix, configs)
    apply_values(configs, fixed)  # a pinned value the configs refuse fails now, not in every trial
    space = build_space(args.task, args.optimizer, args.params, fixed)
    require(bool(space), "nothing to search: every parameter is fixed")
    objective = make_objective(args.task, args.metric, probe(args, fixed), args.direction)
    config_file = None if args.config is None else str(args.config.resolve())
    spec = TrialSpec(
        args.task,
        args.optimizer,
        objective.metric,
        args.seeds,
        args.duration,
        args.episode_latency(),
        config_file,
        fixed,
        conditions=tuple(args.condition_list()),
        aggregate=args.aggregate,
        cvar_alpha=args.cvar_alpha,
        maximize=objective.direction == "maximize",
        sensing=args.sensing(),
        first_seed=args.first_seed,
        plant_overrides=args.plant_overrides,
    )
    target = args.trials
    if args.sampler == "grid":
        target = min(target, studies.grid_size(space))
    sampler = studies.make_sampler(args.sampler, args.seed, space, args.max_plan_ms is not None)
    study_name = args.study or f"{args.task}-{args.optimizer}-{objective.metric}"
    identity = {
        "task": args.task,
        "optimizer": args.optimizer,
        "metric": objective.metric,
        "conditions": "; ".join(condition.label for condition in spec.conditions),
        "aggregate": aggregate_text(spec),
    }
    # a study planning from sensors never resumes one from the full state
    if spec.sensing != Sensing():
        identity["sensing"] = repr(spec.sensing)
    out = args.out_dir()
    storage = args.storage_url()
    study, already, notes = studies.open_study(storage, study_name, objective, sampler, identity)
    if not study.trials and args.sampler != "grid":  # a grid runs its own points only
        studies.enqueue_defaults(study, space, configs)
    out.mkdir(parents=True, exist_ok=True)
    console = output_console()
    console.print(
        f"study {study_name!r} in {storage}: {objective.direction} the "
        f"{aggregate_text(spec)} of {objective.metric} "
        f"over {len(spec.conditions)} conditions ({identity['conditions']}), searching "
        f"{', '.join(p.name for p in space)}"
        + (f"; resuming with {already} finished trials" if already else "")
    )
    # e.g. "resumed: trial 0 was left RUNNING by a process that died; marked FAIL"
    for note in notes:
        console.print(f"resumed: {note}")
    connected = cluster.start_ray(args.address, args.workers or os.cpu_count() or 1)
    capacity = args.workers or cluster.cluster_cpus()
    best_so_far = studies.best_trial(study, objective)
    best_value = None if best_so_far is None else best_so_far.value
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    started = time.perf_counter()
    try:
        with progress_display(*columns) as progress:
            bar = progress.add_task(
                progress_text(objective, best_value), total=target, completed=min(already, target)
            )

            def show(update: studies.Progress) -> None:
                best = studies.best_trial(study, objective)
                progress.update(
                    bar,
                    completed=update.finished,
                    description=progress_text(objective, best and best.value),
                )

            studies.run_trials(study, space, spec, target, capacity, args.max_plan_ms, show)
    except KeyboardInterrupt:
        print(
            f"interrupted: the finished trials are stored in {storage} (study {study_name!r}); "
            "run the same command to resume",
            file=sys.stderr,
        )
        return 130
    finally:
        if connected:
            cluster.stop_ray()
    for note in dead_trial_notes(study):  # a process that died while this one ran
        console.print(note)
    write_outputs(args, study, objective, space, spec, out, time.perf_counter() - started, command)
    finished = studies.finished_trials(study)
    if finished and all(failure_of(trial) for trial in finished):
        reason = failure_of(finished[0])
        print(
            f"python -m judo tune: every trial failed; the first reason: {reason}", file=sys.stderr
        )
        return 1
    return 0


def write_outputs(
    args: TuneArgs,
    study: Any,
    objective: Objective,
    space: list[Param],
    spec: TrialSpec,
    out: Path,
    seconds: float,
    command: str,
) -> None:
    """The table, trials.csv, summary.json, plots, best.toml and the best trial's episode plot."""
    from judo.tuning import report
    from judo.tuning import study as studies

    console = output_console()
    table = report.top_trials_table(study, objective, space)
    table.caption = f"{table.caption}; this run took {seconds:.0f} s"
    console.print(table)
    report.write_trials_csv(out / "trials.csv", study, objective.metric)
    written = [out / "trials.csv", *report.write_study_plots(out, study, objective)]
    best = studies.best_trial(study, objective)
    baseline = studies.baseline_trial(study)
    comparison = None if baseline is None else report.before_after_line(objective, baseline, best)
    if comparison is not None:
        console.print(comparison)
    report.write_summary_json(out / "summary.json", study, objective, best, baseline)
    written.append(out / "summary.json")
    if best is None:
        console.print(
            "no feasible completed trial, so no best.toml"
            + (" (see trials.csv)" if study.trials else "")
        )
    else:
        values = {**spec.fixed, **best.params}
        header = [
            f"Best of study {study.study_name!r}: trial {best.number}, {objective.metric} = "
            f"{best.value:.6g} "
            f"({aggregate_text(spec)} of {len(spec.conditions)} conditions x "
            f"{seeds_label(args.first_seed, args.seeds)} x {args.duration:g} s), "
            f"median plan {best.user_attrs.get('plan_ms') or float('nan'):.3g} ms.",
            "Per condition: "
            + ", ".join(
                f"{label}: {value:.4g}"
                for label, value in best.user_attrs.get("conditions", {}).items()
            ),
            *([] if comparison is None else [comparison]),
            f"Found by: {command}",
            f"Use with: python -m judo --config {out / 'best.toml'}  (or evaluate --config "
            "... --task ... --optimizer ...)",
        ]
        write_best_toml(out / "best.toml", args.task, args.optimizer, values, header)
        written.append(out / "best.toml")
        (episode,) = run_seeded_episodes(spec, best.params, spec.seed_range()[:1])
        model = make_task(args.task).sim_model
        title = (
            f"{args.task} x {args.optimizer}, best trial {best.number}, seed {episode.seed}, "
            f"{spec.conditions[0].label}"
        )
        for suffix in (".html", ".png"):
            try:
                write_episode_plot(episode, model, out / f"best_episode{suffix}", title)
                written.append(out / f"best_episode{suffix}")
            except JudoError:  # .png without matplotlib
                pass
    console.print("wrote " + ", ".join(str(path) for path in written))


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo tune` on `argv` (sys.argv[1:] when None); exits with status 2 on bad
    arguments."""
    argv = merge_repeated(list(sys.argv[1:] if argv is None else argv))
    args = tyro.cli(
        TuneArgs,
        args=argv,
        prog="python -m judo tune",
        description=DESCRIPTION + " " + name_listing(),
    )
    try:
        check_count("--workers", args.workers, MAX_WORKERS)
        check_count("--trials", args.trials, MAX_SAMPLES)
        require_between("--duration", args.duration, 0, MAX_EPISODE, " s", above=True)
        if args.latency_ms is not None:
            require_between("--latency-ms", args.latency_ms, 0, 60_000.0)
        check_output_folder("--out", args.out_dir())
        return tune(args, "python -m judo tune " + shlex.join(argv))
    except JudoError as err:
        fail(str(err))
