"""Trials left RUNNING by a tune whose process died (kill -9, a crash, a lost machine), found by
heartbeats.

Optuna's RDB storage keeps a heartbeat per trial (its `heartbeat_interval` and `grace_period`): a
tune records one for each trial it runs every HEARTBEAT_S seconds (`Heartbeats`; Optuna itself
records them in `study.optimize` only, not for ask and tell), and a RUNNING trial whose heartbeat is
older than STALE_AFTER_S belongs to a process that died: `optuna.storages.fail_stale_trials` marks
it FAIL, which tune does when it opens a study and before it writes its outputs
(`dead_trial_notes`). Optuna is imported by the caller (tuning/study.py's `import_optuna`) before
any of this runs.
"""

import threading
from typing import Any

HEARTBEAT_S = 5
"""Seconds between the heartbeats a tune records for each trial it runs (Optuna's
heartbeat_interval)."""
STALE_AFTER_S = 20
"""A RUNNING trial whose heartbeat is older than this was left by a process that died (Optuna's
grace_period): four missed heartbeats, so that a live tune on a loaded machine is not taken for a
dead one."""
DEAD_PROCESS = f"left RUNNING by a process that died (no heartbeat for {STALE_AFTER_S} s)"
"""The failure of a trial that `fail_dead_trials` marked FAIL (Optuna records no reason for it)."""


def fail_dead_trials(study: Any) -> list[int]:
    """Mark FAIL the RUNNING trials whose heartbeat is older than STALE_AFTER_S (by Optuna's
    `fail_stale_trials`); returns their numbers. A RUNNING trial that never beat (an in-memory
    study) is left."""
    import optuna

    running = {
        trial.number
        for trial in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,))
    }
    if not running:
        return []
    optuna.storages.fail_stale_trials(study)
    failed = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.FAIL,))
    return sorted(trial.number for trial in failed if trial.number in running)


def dead_trial_notes(study: Any) -> list[str]:
    """Fail the trials of dead processes (`fail_dead_trials`) and say so in a line, e.g. "trial 0
    was left RUNNING by a process that died; marked FAIL"; and a line naming the trials still
    RUNNING (another tune's, or of a process that died less than STALE_AFTER_S ago). [] when no
    trial is or was RUNNING."""
    import optuna

    notes = []
    dead = fail_dead_trials(study)
    if len(dead) == 1:
        notes.append(f"trial {dead[0]} was left RUNNING by a process that died; marked FAIL")
    elif dead:
        notes.append(
            f"trials {', '.join(map(str, dead))} were left RUNNING by processes that died; "
            "marked FAIL"
        )
    running = [
        trial.number
        for trial in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,))
    ]
    if running:
        notes.append(
            f"{'trials' if len(running) > 1 else 'trial'} {', '.join(map(str, running))} "
            "still RUNNING: another "
            f"tune runs it, or its process died less than {STALE_AFTER_S} s ago (a later "
            "resume marks it FAIL)"
        )
    return notes


def failure_of(trial: Any) -> str | None:
    """Why a trial failed: its "failure" attribute, DEAD_PROCESS for a FAIL trial without one
    (Optuna's `fail_stale_trials` sets no attribute), or None for a trial that did not fail."""
    reason = trial.user_attrs.get("failure")
    if reason is None and trial.state.name == "FAIL":
        return DEAD_PROCESS
    return reason


class Heartbeats:
    """A thread that records, every HEARTBEAT_S seconds, the heartbeat of each trial this tune is
    running (Optuna records heartbeats in `study.optimize` only, not for ask and tell); a no-op for
    a storage without heartbeats.

    Use as a context manager; `beat(trial)` records the first heartbeat at once and `stop(trial)`
    ends them.
    """

    def __init__(self, study: Any) -> None:
        # the study's RDBStorage (Optuna's fail_stale_trials reads it the same way)
        storage = study._storage
        interval = getattr(storage, "get_heartbeat_interval", lambda: None)()
        self._storage = storage if interval is not None else None
        self._trial_ids: set[int] = set()
        self._lock = threading.Lock()
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._run, name="judo-tune-heartbeats", daemon=True)

    def __enter__(self) -> "Heartbeats":
        if self._storage is not None:
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stopped.set()
        if self._thread.is_alive():
            self._thread.join()

    def beat(self, trial: Any) -> None:
        """Record `trial`'s heartbeat now, and every HEARTBEAT_S seconds until `stop(trial)`."""
        if self._storage is None:
            return
        self._storage.record_heartbeat(trial._trial_id)
        with self._lock:
            self._trial_ids.add(trial._trial_id)

    def stop(self, trial: Any) -> None:
        """No more heartbeats for `trial` (told, or about to be)."""
        with self._lock:
            self._trial_ids.discard(trial._trial_id)

    def _run(self) -> None:
        assert self._storage is not None
        while not self._stopped.wait(HEARTBEAT_S):
            with self._lock:
                trial_ids = sorted(self._trial_ids)
            for trial_id in trial_ids:
                try:
                    self._storage.record_heartbeat(trial_id)
                # a database busy for a moment: the next beat, HEARTBEAT_S later, tries again
                except Exception:
                    pass
