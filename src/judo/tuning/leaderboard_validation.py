"""A leaderboard's validation: each tuned setting and the shipped default, scored on fresh seeds as
Ray tasks.

Each job (a key naming what runs, and the TrialSpec and values it runs with) is one episode per seed
of the spec, run by tune's episode runner (`run_condition_seed`) under the spec's only condition. A
job's scores are stored in validation.json as soon as its last seed is in, so that a Ctrl-C loses at
most the jobs still running and the same command resumes with the others.
"""

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from judo.cli_shared import progress_console, progress_display
from judo.core.errors import JudoError
from judo.evaluation.episode import EpisodeOutcome
from judo.evaluation.shared_options import write_json
from judo.tuning.trial import TrialSpec, run_condition_seed

Jobs = dict[str, tuple[TrialSpec, dict[str, Any]]]
"""{key: (spec, values)}: what to validate, by a key that names the task, the entry, the protocol
and the seeds."""


def validation_episode(
    key: str, spec: TrialSpec, values: dict[str, Any], seed: int
) -> EpisodeOutcome[None]:
    """One validation episode of job `key` (a Ray task): `run_condition_seed` under the spec's only
    condition; never raises."""
    return run_condition_seed(spec, values, 0, seed)


def load_store(path: Path) -> dict[str, Any]:
    """The validations stored at `path` ({} when there is no file yet); JudoError for a file that is
    not one."""
    if not path.is_file():
        return {}
    try:
        store = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise JudoError(
            f"{path} holds no stored validations ({err}); delete it to validate again"
        ) from None
    if not isinstance(store, dict):
        raise JudoError(
            f"{path} holds no stored validations (expected a JSON object); delete it to validate "
            "again"
        )
    return store


def save_store(path: Path, store: dict[str, Any]) -> None:
    """Write `store` to `path` whole or not at all (a temporary file, then renamed), so that a
    Ctrl-C while it is written leaves the previous store."""
    temporary = path.with_name(path.name + ".tmp")
    write_json(temporary, store)
    os.replace(temporary, path)


def stored_job(spec: TrialSpec, outcomes: list[EpisodeOutcome[None]]) -> dict[str, Any]:
    """A finished job as stored: "scores" (S,) the metric per seed in seed order ([] when an episode
    failed), "failure" (the first seed's reason, or None) and "plan_ms" (the median control
    update)."""
    runs = sorted(outcomes, key=lambda outcome: outcome.seed)
    failure = next((run.failure for run in runs if run.failure is not None), None)
    update_ms = np.concatenate([run.update_ms for run in runs])
    return {
        "scores": [] if failure else [float(run.metrics[spec.metric]) for run in runs],
        "failure": failure,
        "plan_ms": float(np.median(update_ms)) if len(update_ms) else None,
    }


def validate(jobs: Jobs, store_path: Path, address: str | None, cpus: int) -> dict[str, Any]:
    """Run the episodes of the `jobs` not yet stored at `store_path` as Ray tasks (`run_windowed`,
    under its own progress bar), storing each job once its seeds are in; returns every stored job,
    {key: stored_job}. Ctrl-C raises KeyboardInterrupt with the finished jobs stored."""
    import judo.ray_cluster as cluster

    store = load_store(store_path)
    todo = {key: job for key, job in jobs.items() if key not in store}
    outcomes: dict[str, list[EpisodeOutcome[None]]] = {key: [] for key in todo}
    counts = cluster.EpisodeCounts()

    def take(task_args: tuple, outcome: EpisodeOutcome[None]) -> None:
        key, spec = task_args[0], task_args[1]
        counts.done += 1
        counts.failed += outcome.failure is not None
        outcomes[key].append(outcome)
        if len(outcomes[key]) == spec.seeds:
            store[key] = stored_job(spec, outcomes[key])
            save_store(store_path, store)

    tasks = [
        (key, spec, values, seed)
        for key, (spec, values) in todo.items()
        for seed in spec.seed_range()
    ]
    if tasks:
        cluster.run_windowed(
            validation_episode,
            tasks,
            take,
            lambda task_args, reason: EpisodeOutcome.failed(task_args[3], reason),
            counts,
            label="validate",
            episodes=len(tasks),
            address=address,
            local_cpus=cpus,
            window=None,
            console=progress_console(),
            progress=progress_display,
        )
    return store
