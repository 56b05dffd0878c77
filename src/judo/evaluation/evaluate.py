"""`python -m judo evaluate`: closed-loop episodes over seeds, the task's success metrics with 95%
CIs."""

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np
import tyro
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

from judo.cli_shared import (
    apply_config_file,
    fail,
    name_listing,
    optional_fields,
    output_console,
    parse_args_with_config_fields,
    progress_console,
    progress_display,
    seeds_label,
)
from judo.core.commandline.boundary import (
    MAX_WORKERS,
    check_count,
    check_output_file,
    check_seed_range,
)
from judo.core.configuration.config import require, require_between
from judo.core.configuration.registry import make_task
from judo.core.errors import JudoError
from judo.core.rollouts.backend import RolloutBackend
from judo.evaluation.episode import EpisodeOutcome, EpisodeResult, unserved_line
from judo.evaluation.episode_args import EpisodeArgs
from judo.evaluation.plot import check_plot_path, write_episode_plot
from judo.evaluation.report import episode_record, metrics_table, summarize_metrics, update_caption
from judo.evaluation.seeded import (
    EpisodeSpec,
    evaluate_seed,
    planning_model,
    run_seeded_episode,
    run_side_by_side,
)
from judo.evaluation.shared_options import given_fields, write_json
from judo.safety.config import SafetyConfig
from judo.safety.limits import set_task_limits

DESCRIPTION = (
    "Run closed-loop episodes of a task with an optimizer, headless and as fast as the "
    "machine allows, one per "
    "seed (--first-seed, --first-seed + 1, ...; 0, 1, ... by default), each from the task's "
    "randomised start, and print each success metric's mean with its 95% "
    "confidence interval over seeds. With --latency measured or --latency-ms the plant keeps "
    "moving while a plan "
    "is computed, and the plan takes effect that much later. With --observe sensors the "
    "planner sees only the "
    "task's measured sensors (noisy, late, at their rates: --sensor-*) through --estimator "
    "(by default the "
    "task's own: ukf for walker and leap_cube, legged for the Unitree robots, else ekf)."
)


SafetyOverrides = optional_fields(SafetyConfig, "SafetyOverrides")
"""`--safety.FIELD VALUE` options of evaluate: every SafetyConfig field (docs/safety.md), None when
not given."""


@dataclass
class EvaluateArgs(EpisodeArgs):
    """Arguments of `python -m judo evaluate`."""

    seeds: int = 5
    """Episodes to run, with seeds first_seed to first_seed + seeds - 1."""
    first_seed: int = 0
    """Seed of the first episode: e.g. --first-seed 100 --seeds 20 runs seeds 100 to 119, to score a
    policy on seeds its training data (collect --first-seed) never held."""
    num_workers: Annotated[
        int | None, tyro.conf.arg(metavar="INT", help_behavior_hint="(default: one per core)")
    ] = None
    """Rollout worker threads (cpu backend)."""
    workers: Annotated[
        int | None, tyro.conf.arg(metavar="K", help_behavior_hint="(default: in this process)")
    ] = None
    """Run the seeds as Ray tasks, K at once, on a local Ray with K CPUs (each on one rollout thread
    unless --num-workers is given); the metrics are those of the in-process run. Needs pip install
    -e '.[tune]'."""
    address: Annotated[
        str | None, tyro.conf.arg(metavar="ADDRESS", help_behavior_hint="(optional)")
    ] = None
    """Run the seeds as Ray tasks on a running Ray cluster: auto (the one `ray start --head` started
    on this machine) or ray://HOST:10001; with --workers, at most K at once."""
    json: Annotated[Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")] = (
        None
    )
    """Also write each episode's metrics and the summary to this JSON file."""
    plot: Annotated[Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")] = (
        None
    )
    """Also plot the first seed's episode against time to this .png (needs matplotlib) or .html
    file."""
    safety: SafetyOverrides = field(default_factory=SafetyOverrides)  # pyright: ignore[reportInvalidTypeForm]
    """The owner's limits (docs/safety.md), over the task's and the --config file's
    [safety.TASK]."""
    # EpisodeArgs has the task, optimizer, episode, latency, backend, --controller.FIELD and sensing
    # options; parse_args_with_config_fields adds `optimizer_config` (--optimizer-config.FIELD, e.g.
    # --optimizer-config.sigma 0.3) and `task_config` (--task-config.FIELD), typed for the pair
    # named.

    def validate(self) -> None:
        """Raise a JudoError for an argument out of range, a name that is not registered, or a bad
        plot path."""
        self.check()
        require_between("--seeds", self.seeds, 1, 10_000)
        check_seed_range(self.first_seed, self.seeds, "--seeds")
        require(
            self.num_workers is None or self.num_workers >= 1,
            f"--num-workers must be at least 1, got {self.num_workers}",
        )
        require(
            self.episodes_per_batch == 1 or (self.workers is None and self.address is None),
            f"--episodes-per-batch {self.episodes_per_batch} runs the episodes side by side "
            "in this process; "
            "expected no --workers or --address",
        )
        if self.plot is not None:
            check_plot_path(self.plot)
        require(
            self.policy is None or self.proposal_policy is None,
            "--proposal-policy proposes candidates to an optimizer's plan, but --policy "
            "drives the plant itself; give one",
        )

    def seed_range(self) -> range:
        """The seeds to run: first_seed to first_seed + seeds - 1."""
        return range(self.first_seed, self.first_seed + self.seeds)

    def episode_spec(self) -> EpisodeSpec:
        """What determines each seed's episode, for the one seeded episode runner here or on Ray."""
        on_ray = self.workers is not None or self.address is not None
        return self.spec((self.num_workers or 1) if on_ray else self.num_workers)


def apply_safety_flags(args: EvaluateArgs) -> None:
    """Make the given `--safety.*` fields the task's [safety] defaults in this process, checked
    against its model; a JudoError for a bad value, or for Ray episodes, whose processes read limits
    only from --config."""
    given = given_fields(args.safety)
    if not given:
        return
    require(
        args.workers is None and args.address is None,
        "--safety.* sets limits in this process only; with --workers or --address give them "
        "as [safety.TASK] in --config",
    )
    set_task_limits(args.task, given)


def evaluate(args: EvaluateArgs, progress: Progress | None = None) -> list[EpisodeResult]:
    """Run one episode per seed of `args.seed_range()` in this process, one after the other; advance
    `progress` (if given) by sim seconds."""
    bar = (
        None
        if progress is None
        else progress.add_task("evaluate", total=args.seeds * args.duration)
    )
    spec = args.episode_spec()
    results = []
    for done, seed in enumerate(args.seed_range()):

        def show(now: float, seed: int = seed, done: int = done) -> None:
            if progress is not None and bar is not None:
                progress.update(
                    bar, completed=done * args.duration + now, description=f"seed {seed}"
                )

        results.append(run_seeded_episode(spec, seed, on_update=show))
    return results


def evaluate_batched(args: EvaluateArgs, progress: Progress | None = None) -> list[EpisodeResult]:
    """Run the seeds of `args.seed_range()` in groups of `args.episodes_per_batch`, each group side
    by side with its rollouts batched on one WarpRollout (`run_side_by_side`); advance `progress`
    (if given) by sim seconds."""
    from judo.core.rollouts.warp_rollout import WarpRollout

    bar = (
        None
        if progress is None
        else progress.add_task("evaluate", total=args.seeds * args.duration)
    )
    spec, seeds = args.episode_spec(), list(args.seed_range())
    size = args.episodes_per_batch
    results: list[EpisodeResult] = []
    with WarpRollout(planning_model(spec)) as backend:
        for start in range(0, len(seeds), size):
            group = seeds[start : start + size]
            times = dict.fromkeys(group, 0.0)

            def run(
                seed: int, slot: RolloutBackend, start: int = start, times: dict = times
            ) -> EpisodeResult:
                def show(now: float) -> None:
                    times[seed] = now
                    if progress is not None and bar is not None:
                        done = start * args.duration + sum(times.values())
                        progress.update(
                            bar, completed=done, description=f"seeds {min(times)}-{max(times)}"
                        )

                return run_seeded_episode(spec, seed, on_update=show, backend=slot)

            results.extend(run_side_by_side(backend, group, run))
    return results


def evaluate_on_ray(
    spec: EpisodeSpec, seeds: range, workers: int | None, address: str | None
) -> tuple[list[EpisodeResult], list[tuple[int, str]]]:
    """Run the seeds `seeds` of `spec` as Ray tasks (`evaluate_seed`, each sending its EpisodeResult
    back, log included) on a local Ray with `workers` CPUs (address None) or the cluster at
    `address`, at most `workers` at once (twice the Ray's CPUs without it); returns (the episodes
    that ran, by seed; (seed, reason) of those that failed). Ctrl-C cancels the running tasks and
    raises KeyboardInterrupt."""
    import os

    import judo.ray_cluster as cluster

    cluster.import_ray("python -m judo evaluate --workers/--address", "tune")
    outcomes: list[EpisodeOutcome[EpisodeResult]] = []
    counts = cluster.EpisodeCounts()

    def take(_: tuple, outcome: EpisodeOutcome[EpisodeResult]) -> None:
        outcomes.append(outcome)
        counts.done += 1
        counts.failed += outcome.episode is None

    cluster.run_windowed(
        evaluate_seed,
        [(spec, seed) for seed in seeds],
        take,
        lambda args, reason: EpisodeOutcome.failed(args[1], reason),
        counts,
        label="evaluate",
        episodes=len(seeds),
        address=address,
        local_cpus=workers or os.cpu_count() or 1,
        window=workers,
        console=progress_console(),
        progress=progress_display,
    )
    outcomes.sort(key=lambda outcome: outcome.seed)
    results = [outcome.episode for outcome in outcomes if outcome.episode is not None]
    failures = [
        (outcome.seed, outcome.failure or "unknown failure")
        for outcome in outcomes
        if outcome.episode is None
    ]
    return results, failures


def run_seeds(args: EvaluateArgs) -> tuple[list[EpisodeResult], list[tuple[int, str]]]:
    """(the episodes, by seed; (seed, reason) of those that failed): in this process, or as Ray
    tasks with --workers or --address (where a failed seed does not stop the others)."""
    if args.workers is not None or args.address is not None:
        return evaluate_on_ray(args.episode_spec(), args.seed_range(), args.workers, args.address)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
    )
    with progress_display(*columns, TimeRemainingColumn()) as progress:
        if args.episodes_per_batch > 1:
            return evaluate_batched(args, progress), []
        return evaluate(args, progress), []


def main(argv: list[str] | None = None) -> int:
    """Run the evaluation on `argv` (sys.argv[1:] when None); returns 0, or 1 when a seed failed on
    Ray (or, with --strict, when an update failed or the simulation diverged); exits with status 2
    on bad arguments."""
    args = parse_args_with_config_fields(
        EvaluateArgs, argv, "python -m judo evaluate", DESCRIPTION + " " + name_listing()
    )
    troubled = 0  # episodes with failed updates or divergences
    try:
        check_count("--num-workers", args.num_workers, MAX_WORKERS)
        check_count("--workers", args.workers, MAX_WORKERS)
        check_output_file("--json", args.json)
        check_output_file("--plot", args.plot)
        apply_config_file(args.config)
        args.validate()
        apply_safety_flags(args)
        # the episodes' configs: the registered ones and the flags (spec.values)
        results, failures = run_seeds(args)
        for seed, reason in failures:
            print(f"seed {seed} failed: {reason}", file=sys.stderr)
        if not results:
            return 1
        summaries = summarize_metrics(results)
        update_ms = np.concatenate([result.update_ms for result in results])
        title = (
            f"{args.task} x {args.controller_label()}: "
            f"{seeds_label(args.first_seed, args.seeds)} x {args.duration:g} s"
            f", latency {args.latency_label()}"
            f"{args.sensing_label()}"
        )
        changed = args.changed_fields()
        if changed:
            title += ", " + ", ".join(
                f"{name.removeprefix('controller.')}={value}" for name, value in changed.items()
            )
        console = output_console()
        table = metrics_table(title, summaries)
        table.caption = update_caption(update_ms, args.policy is not None)
        console.print(table)
        for result in results:
            if result.divergences or result.failed_updates:
                troubled += 1
                console.print(
                    f"seed {result.seed}: {result.divergences} simulation divergences, "
                    f"{result.failed_updates} updates with "
                    + ("non-finite actions" if args.policy is not None else "no finite reward")
                )
            # [safety] limits in force: what the serve filter and the screen did
            if "limit_hits" in result.metrics:
                hits = (
                    ", ".join(
                        f"{name} {count}" for name, count in sorted(result.limit_hits.items())
                    )
                    or "none"
                )
                console.print(
                    f"seed {result.seed}: limit hits: {hits}; {result.no_feasible} planning "
                    "iterations had no "
                    "feasible sample (the least-violating plan was served)"
                )
            loud = unserved_line(
                result.failed_updates,
                len(result.update_ms),
                args.policy is not None,
                f"seed {result.seed}",
            )
            if loud is not None:
                print(loud, file=sys.stderr)
        if args.json is not None:
            write_json(
                args.json,
                {
                    "task": args.task,
                    "optimizer": args.optimizer,
                    "policy": args.policy_file(),
                    "seeds": args.seeds,
                    "first_seed": args.first_seed,
                    "duration": args.duration,
                    "latency": args.latency_label(),
                    "sensing": args.sensing_record(),
                    "backend": args.backend,
                    "controller": given_fields(args.controller),
                    "proposal_policy": None
                    if args.proposal_policy is None
                    else str(args.proposal_policy),
                    "overrides": changed,
                    "episodes": [episode_record(result) for result in results],
                    "summary": {name: vars(summary) for name, summary in summaries.items()},
                },
            )
            console.print(f"wrote {args.json}")
        if args.plot is not None:
            model = make_task(args.task).sim_model
            write_episode_plot(results[0], model, args.plot, f"{title}, seed {results[0].seed}")
            console.print(f"wrote {args.plot}")
    except JudoError as err:
        fail(str(err))
    if args.strict and troubled:
        print(
            f"--strict: {troubled} of {len(results)} episodes had failed control updates or "
            "simulation divergences",
            file=sys.stderr,
        )
        return 1
    return 1 if failures else 0
