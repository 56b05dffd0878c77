"""A tune trial's episodes as Ray tasks: submit each (condition, seed) episode, and read back its outcome.

Ray itself (starting or joining it, waiting, cancelling) is judo.ray_cluster's, shared with evaluate and collect.
"""

from typing import Any

import numpy as np

from judo.ray_cluster import import_ray
from judo.tuning.trial import EpisodeOutcome, TrialSpec, run_condition_seed


def submit_trial(spec: TrialSpec, values: dict[str, Any]) -> list[Any]:
    """Start each episode of a trial, `run_condition_seed(spec, values, condition, seed)` for every condition
    and seed, as a Ray task needing one CPU; returns their ObjectRefs."""
    ray = import_ray()
    remote = ray.remote(num_cpus=1, max_retries=0)(run_condition_seed)
    return [
        remote.remote(spec, values, condition, seed)
        for condition in range(len(spec.conditions))
        for seed in spec.seed_range()
    ]


def outcome_of(ref: Any, condition: int, seed: int) -> EpisodeOutcome:
    """The EpisodeOutcome of a finished ref (episode `seed` of condition number `condition`); a failed one
    when the Ray task itself died (e.g. a worker crash)."""
    ray = import_ray()
    try:
        return ray.get(ref)
    except Exception as err:  # noqa: BLE001  (RayTaskError, WorkerCrashedError, ...)
        return EpisodeOutcome(condition, seed, {}, np.zeros(0), f"Ray task failed: {type(err).__name__}: {err}")
