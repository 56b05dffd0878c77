"""The collect driver: submit the missing seeds as Ray tasks, write each finished episode, show
progress.

Only this driver writes the file, one finished episode at a time
(judo.recording.dataset.DatasetFile). At most --workers episodes are in flight (two per CPU of the
Ray without it), so a long run holds little in memory and --workers means the same on a local Ray
and a cluster.
"""

import sys
from typing import Any

from judo.cli_shared import output_console, progress_console, progress_display
from judo.collection.episode import collect_group
from judo.core.errors import JudoError
from judo.evaluation.episode import EpisodeOutcome
from judo.evaluation.seeded import EpisodeSpec
from judo.ray_cluster import EpisodeCounts
from judo.recording.dataset import DatasetFile, EpisodeArrays

SHOWN_FAILURES = 5
"""Failed seeds listed with their reasons at the end of a run (all of them are in the file)."""


class NoSuccessRuleError(JudoError):
    """--success-only for a task whose `success(metrics)` has no rule for its metrics."""


class Tally(EpisodeCounts):
    """Counts of this run's episodes, for the progress bar and the closing line."""

    def __init__(self) -> None:
        super().__init__()
        self.kept = self.dropped = 0
        # episodes with some, and with only, failed control updates
        self.with_failed_updates = self.unserved = 0
        self.failures: list[tuple[int, str]] = []

    def detail(self) -> str:
        """kept, and dropped when some were."""
        return f", kept {self.kept}" + (f", dropped {self.dropped}" if self.dropped else "")


def write_outcome(
    file: DatasetFile,
    outcome: EpisodeOutcome[EpisodeArrays],
    success_only: bool,
    tally: Tally,
    task: str,
) -> None:
    """Write one finished episode (or its failure, or its dropping) to `file` and count it."""
    tally.done += 1
    episode = outcome.episode
    if episode is None:
        tally.failed += 1
        reason = outcome.failure or "unknown failure"
        tally.failures.append((outcome.seed, reason))
        file.write_failure(outcome.seed, reason)
        return
    if outcome.failed_updates:
        tally.with_failed_updates += 1
        tally.unserved += outcome.failed_updates >= outcome.num_updates > 0
    if success_only and episode.success is None:
        raise NoSuccessRuleError(
            f"--success-only: task {task!r} has no success rule for its metrics "
            f"{sorted(episode.metrics)}; "
            "give the task a `success(self, metrics) -> bool` method, or report a 'success' metric"
        )
    if success_only and not episode.success:
        tally.dropped += 1
        file.write_dropped(episode.seed, episode.metrics)
        return
    tally.kept += 1
    file.write_episode(episode)


def collect(
    spec: EpisodeSpec, env_args: dict[str, Any], args: Any, command: str, workers: int
) -> int:
    """Run the seeds of args.first_seed..args.first_seed+args.episodes-1 missing from `args.out` and
    write them there; returns the exit status (130 after Ctrl-C, with the command that resumes
    printed; 1 with --strict when a control update failed)."""
    import judo.ray_cluster as cluster

    file = DatasetFile(args.out, env_args)
    finished = file.finished_seeds()
    wanted = range(args.first_seed, args.first_seed + args.episodes)
    todo = [seed for seed in wanted if seed not in finished]
    console = output_console()
    if not todo:
        counts = file.counts()
        console.print(
            f"{args.out} already holds seeds {wanted[0]} to {wanted[-1]}: {counts['kept']} "
            "episodes kept"
        )
        return 0
    if len(todo) < len(wanted):
        console.print(
            f"{args.out}: {len(wanted) - len(todo)} seeds done; running the {len(todo)} missing "
            "ones"
        )
    cluster.import_ray("python -m judo collect", "collect")
    tally = Tally()
    # seeds per Ray task: side by side on one warp backend when more than one
    size = args.episodes_per_batch

    def take(_: tuple, outcomes: list[EpisodeOutcome[EpisodeArrays]]) -> None:
        for outcome in outcomes:
            write_outcome(file, outcome, args.success_only, tally, spec.task)

    def lost(task: tuple, reason: str) -> list[EpisodeOutcome[EpisodeArrays]]:
        return [EpisodeOutcome.failed(seed, reason) for seed in task[1]]

    try:
        cluster.run_windowed(
            collect_group,
            [(spec, todo[i : i + size], args.traces) for i in range(0, len(todo), size)],
            take,
            lost,
            tally,
            label="collect",
            episodes=len(todo),
            address=args.address,
            local_cpus=workers,
            window=args.workers,  # --workers caps the episodes run at once on any Ray
            console=progress_console(),
            per_task=size,
            progress=progress_display,  # plain lines every few seconds where stderr is no terminal
        )
    except KeyboardInterrupt:
        print(
            f"interrupted: {tally.kept} finished episodes of this run are in {args.out}; "
            f"resume with:\n  {command}",
            file=sys.stderr,
        )
        return 130
    report(console, file, args, tally)
    if args.strict and tally.with_failed_updates:
        print(
            f"--strict: {tally.with_failed_updates} of {tally.done} episodes had failed "
            "control updates",
            file=sys.stderr,
        )
        return 1
    return 0


def report(console: Any, file: DatasetFile, args: Any, tally: Tally) -> None:
    """The closing lines: what this run added, what was dropped and why episodes failed."""
    counts = file.counts()
    console.print(
        f"{tally.line()}; {args.out} holds {counts['kept']} episodes, {counts['total']} samples"
    )
    if args.success_only:
        console.print(
            f"--success-only: dropped {tally.dropped} of {tally.done - tally.failed} episodes run"
        )
    for seed, reason in tally.failures[:SHOWN_FAILURES]:
        console.print(f"seed {seed} failed: {reason}")
    if len(tally.failures) > SHOWN_FAILURES:
        console.print(
            f"... and {len(tally.failures) - SHOWN_FAILURES} more (attributes of judo/failed in "
            "the file)"
        )
    if tally.unserved:
        what = "non-finite actions" if args.policy is not None else "no finite reward"
        print(
            f"warning: in {tally.unserved} of {tally.done} episodes every control update "
            f"gave {what}, so every "
            "action stored is the task's safe action, not a plan's; --strict makes this exit 1",
            file=sys.stderr,
        )
    elif tally.with_failed_updates:
        console.print(
            f"{tally.with_failed_updates} episodes had control updates that failed (safe action "
            "served)"
        )
