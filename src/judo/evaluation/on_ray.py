"""`evaluate --workers K` / `--address ADDR`: each seed's episode as a Ray task, as collect and tune run theirs.

Every task runs `judo.evaluation.seeded.evaluate_seed` (the one seeded episode runner, on one rollout thread
unless --num-workers says otherwise) and sends the EpisodeResult back, log included, so the table, --json
and --plot are those of the in-process run, seed for seed. At most --workers episodes are in flight (twice
the Ray's CPUs without it). Ctrl-C cancels the running tasks and exits 130.
"""

import time
from typing import Any

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from judo.cli_shared import progress_console
from judo.evaluation.episode import EpisodeResult
from judo.evaluation.seeded import EpisodeSpec, SeedOutcome, evaluate_seed

FEATURE = "python -m judo evaluate --workers/--address"
"""What needs Ray, as a missing extra's message names it."""


class Counts:
    """Finished and failed episodes, and the rate, for the progress bar."""

    def __init__(self) -> None:
        self.done = self.failed = 0
        self.started = time.perf_counter()

    def line(self) -> str:
        """done, failed and episodes per minute."""
        minutes = (time.perf_counter() - self.started) / 60.0
        rate = self.done / minutes if minutes > 0 else 0.0
        return f"done {self.done}, failed {self.failed}, {rate:.1f} episodes/min"


def outcome_of(ray: Any, ref: Any, seed: int) -> SeedOutcome:
    """The SeedOutcome of a finished ref; a failure when the Ray task itself died (e.g. a worker crash)."""
    try:
        return ray.get(ref)
    except Exception as err:  # noqa: BLE001  (RayTaskError, WorkerCrashedError, ...)
        return SeedOutcome(seed, None, f"Ray task failed: {type(err).__name__}: {err}")


def evaluate_on_ray(
    spec: EpisodeSpec, seeds: range, workers: int | None, address: str | None
) -> tuple[list[EpisodeResult], list[tuple[int, str]]]:
    """Run the seeds `seeds` of `spec` as Ray tasks on a local Ray with `workers` CPUs (address None) or the
    cluster at `address`; returns (the episodes that ran, by seed; (seed, reason) of those that failed)."""
    import os

    import judo.ray_cluster as cluster

    ray = cluster.import_ray(FEATURE, "tune")
    outcomes: list[SeedOutcome] = []
    counts = Counts()
    running: dict[Any, int] = {}
    pending = iter(seeds)
    columns = (TextColumn("evaluate"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"))
    connected = False
    try:
        connected = cluster.start_ray(address, workers or os.cpu_count() or 1)
        window = workers or 2 * cluster.cluster_cpus()
        with Progress(*columns, TimeElapsedColumn(), console=progress_console(), transient=True) as progress:
            bar = progress.add_task(counts.line(), total=len(seeds))
            while True:
                while len(running) < window and (seed := next(pending, None)) is not None:
                    running[cluster.submit(evaluate_seed, spec, seed)] = seed
                if not running:
                    break
                ready, _ = cluster.wait_any(list(running))
                for ref in ready:
                    outcome = outcome_of(ray, ref, running.pop(ref))
                    outcomes.append(outcome)
                    counts.done += 1
                    counts.failed += outcome.result is None
                progress.update(bar, completed=counts.done, description=counts.line())
    except BaseException:  # Ctrl-C, or Ray refusing: cancel what is still running
        cluster.cancel(list(running))
        raise
    finally:
        if connected:
            cluster.stop_ray()
    outcomes.sort(key=lambda outcome: outcome.seed)
    results = [outcome.result for outcome in outcomes if outcome.result is not None]
    failures = [(outcome.seed, outcome.failure or "unknown failure") for outcome in outcomes if outcome.result is None]
    return results, failures
