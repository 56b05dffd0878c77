"""The Optuna study of a tune: its storage, its sampler, and the ask/tell loop that keeps the Ray
workers busy.

Each trial's settings are asked for while other trials run; a finished trial is told at once, so the
study in the database holds every finished trial and a crash or Ctrl-C loses none of them. A Ctrl-C
is held off while a trial is asked for, submitted or told, so that every trial the loop started is
either told or known to it (and failed as "interrupted"). Each running trial's heartbeat is kept in
the storage (Optuna's RDB heartbeat): a trial left RUNNING by a process that died (kill -9, a crash)
stops beating, and opening the study again marks it FAIL (tuning/heartbeat.py). Trial user
attributes: "metrics" (each metric's mean over seeds and conditions), "conditions" (the objective
metric's mean over seeds under each condition, by label), "plan_ms" (median control update),
"failure" (why a trial failed), and with --max-plan-ms "constraint" ([plan_ms - max_plan_ms],
feasible when <= 0), also set as the trial's Optuna constraint, which the TPE sampler takes into
account.
"""

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Literal

import numpy as np

from judo.core.commandline.interrupts import sigint_deferred
from judo.core.configuration.config import Config
from judo.core.configuration.registry import ConfigKind
from judo.core.errors import JudoError, import_extra
from judo.evaluation.episode import EpisodeOutcome
from judo.ray_cluster import cancel, get, submit, wait_any
from judo.tuning.heartbeat import HEARTBEAT_S, STALE_AFTER_S, Heartbeats, dead_trial_notes
from judo.tuning.objective import Objective
from judo.tuning.space import Param
from judo.tuning.trial import TrialOutcome, TrialSpec, run_condition_seed, score_trial

SamplerName = Literal["tpe", "cmaes", "random", "grid"]
GRID_POINTS = 3
"""Values per parameter on the grid of --sampler grid (ints and choices may have fewer)."""


class StudyError(JudoError):
    """A storage that cannot be opened, or a --study that was made for another task, optimizer or
    metric."""


def import_optuna() -> Any:
    """The optuna module, or MissingExtraError naming the `tune` extra."""
    optuna = import_extra("optuna", "python -m judo tune", "tune")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    # Optuna records heartbeats in study.optimize only and warns of ask-and-tell with them: tune
    # records them itself
    warnings.filterwarnings(
        "ignore", message="Heartbeat of storage is supposed to be used with Study.optimize"
    )
    return optuna


def constraint_of(trial: Any) -> list[float]:
    """The trial's constraint values (feasible when all <= 0), from its user attributes."""
    return list(trial.user_attrs.get("constraint", [0.0]))


def grid_values(param: Param, points: int = GRID_POINTS) -> list[Any]:
    """The grid of `param`: its choices, or `points` values spaced evenly (on a log scale when it is
    log)."""
    if param.choices:
        return list(param.choices)
    spaced = (
        np.geomspace(param.low, param.high, points)
        if param.log
        else np.linspace(param.low, param.high, points)
    )
    if param.integer:
        return sorted({int(round(v)) for v in spaced})
    return [float(v) for v in spaced]


def make_sampler(name: SamplerName, seed: int, space: list[Param], constrained: bool) -> Any:
    """The seeded Optuna sampler `name`; TPE honours the plan-time constraint."""
    optuna = import_optuna()
    if name == "tpe":
        if constrained and not hasattr(optuna.trial.Trial, "set_constraint"):  # optuna 4
            return optuna.samplers.TPESampler(seed=seed, constraints_func=constraint_of)
        return optuna.samplers.TPESampler(seed=seed)
    if name == "cmaes":
        import_extra("cmaes", "--sampler cmaes", "tune")
        return optuna.samplers.CmaEsSampler(seed=seed, warn_independent_sampling=False)
    if name == "random":
        return optuna.samplers.RandomSampler(seed=seed)
    if name == "grid":
        return optuna.samplers.GridSampler({p.name: grid_values(p) for p in space}, seed=seed)
    raise StudyError(f"unknown sampler {name!r}; valid samplers are: tpe, cmaes, random, grid")


def grid_size(space: list[Param]) -> int:
    """How many trials a full grid has."""
    return math.prod(len(grid_values(p)) for p in space)


def sqlite_folder(storage: str) -> Path | None:
    """The folder of a sqlite:/// storage's file (to create it), or None for other URLs."""
    prefix = "sqlite:///"
    if not storage.startswith(prefix) or storage == prefix or ":memory:" in storage:
        return None
    return Path(storage[len(prefix) :]).parent


def open_study(
    storage: str, study_name: str, objective: Objective, sampler: Any, identity: dict[str, str]
) -> tuple[Any, int, list[str]]:
    """Create the study, or load it when it exists; returns (study, number of finished trials it
    already has, `dead_trial_notes`: the trials of a dead process it marked FAIL first, and those
    still RUNNING).

    `identity` ({"task": ..., "optimizer": ..., "metric": ...}) is stored with a new study and must
    match on resume. Raises StudyError for a storage URL Optuna cannot open.
    """
    optuna = import_optuna()
    folder = sqlite_folder(storage)
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    try:
        rdb = optuna.storages.RDBStorage(
            storage, heartbeat_interval=HEARTBEAT_S, grace_period=STALE_AFTER_S
        )
        study = optuna.create_study(
            storage=rdb,
            study_name=study_name,
            direction=objective.direction,
            sampler=sampler,
            load_if_exists=True,
        )
    except Exception as err:  # sqlalchemy and optuna raise many kinds for a bad URL
        first_line = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise StudyError(
            f"cannot open the study storage {storage!r}: {first_line}. Expected an Optuna "
            "RDB URL such as "
            "sqlite:///judo-tune.db or postgresql://user:password@host/database"
        ) from None
    stored = study.user_attrs
    if not stored:
        for key, value in identity.items():
            study.set_user_attr(key, value)
    else:
        mismatched = {
            key: (stored.get(key), value)
            for key, value in identity.items()
            if stored.get(key) != value
        }
        if mismatched:
            what = ", ".join(
                f"{key} {old!r} (asked for {new!r})" for key, (old, new) in mismatched.items()
            )
            raise StudyError(
                f"study {study_name!r} in {storage} was made for {what}; pick another "
                "--study name to start a new one"
            )
    if study.direction.name.lower() != objective.direction:
        raise StudyError(
            f"study {study_name!r} {study.direction.name.lower()}s its metric, not "
            f"{objective.direction}; "
            "pick another --study name"
        )
    notes = dead_trial_notes(study)
    return study, len(finished_trials(study)), notes


def finished_trials(study: Any) -> list[Any]:
    """The trials that completed or failed (not those left running by an interrupted run)."""
    optuna = import_optuna()
    states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL)
    return study.get_trials(deepcopy=False, states=states)


def suggest(trial: Any, space: list[Param]) -> dict[str, Any]:
    """The trial's value for each parameter of `space`, by name."""
    values: dict[str, Any] = {}
    for param in space:
        if param.choices:
            values[param.name] = trial.suggest_categorical(param.name, list(param.choices))
        elif param.integer:
            values[param.name] = trial.suggest_int(
                param.name, int(param.low), int(param.high), log=param.log
            )
        else:
            values[param.name] = trial.suggest_float(
                param.name, param.low, param.high, log=param.log
            )
    return values


def tell(study: Any, trial: Any, outcome: TrialOutcome, max_plan_ms: float | None) -> None:
    """Record `outcome` on the trial: complete with its value, or failed with the reason."""
    optuna = import_optuna()
    trial.set_user_attr("metrics", outcome.metrics)
    if outcome.conditions:
        trial.set_user_attr("conditions", outcome.conditions)
    trial.set_user_attr("plan_ms", None if math.isnan(outcome.plan_ms) else outcome.plan_ms)
    if outcome.failed:
        trial.set_user_attr("failure", outcome.failure)
        study.tell(trial, state=optuna.trial.TrialState.FAIL)
        return
    if max_plan_ms is not None:
        trial.set_user_attr("constraint", [outcome.plan_ms - max_plan_ms])
        if hasattr(trial, "set_constraint"):  # optuna 5: the samplers read it from the trial
            trial.set_constraint("plan_ms_over_max", outcome.plan_ms - max_plan_ms)
    study.tell(trial, outcome.value)


@dataclass
class Progress:
    """What the loop reports after each finished trial."""

    finished: int
    target: int
    last: TrialOutcome


def run_trials(
    study: Any,
    space: list[Param],
    spec: TrialSpec,
    target: int,
    concurrency: int,
    max_plan_ms: float | None,
    on_trial: Callable[[Progress], None] | None = None,
) -> None:
    """Run trials on Ray until the study has `target` finished trials, keeping about `concurrency`
    episodes running.

    Each trial's episodes (a condition x a seed each) are Ray tasks of their own; a new trial is
    asked for while fewer than `concurrency` episodes are pending, and a trial is told once all its
    episodes are in. On Ctrl-C the running trials are cancelled and stored as failed
    ("interrupted"), and KeyboardInterrupt is raised again; every finished trial is already in the
    storage. A Ctrl-C that lands while trials are asked for and submitted, or told, takes effect
    once that is done, so that no trial is left RUNNING. Each running trial's heartbeat is recorded
    every HEARTBEAT_S seconds (`Heartbeats`).
    """
    optuna = import_optuna()
    finished = len(finished_trials(study))
    to_start = target - finished
    pending: dict[Any, tuple[int, int, int]] = {}  # ObjectRef -> (trial number, condition, seed)
    # trial number -> (optuna Trial, episodes so far)
    running: dict[int, tuple[Any, list[EpisodeOutcome[None]]]] = {}
    per_trial = len(spec.conditions) * spec.seeds
    with Heartbeats(study) as heartbeats:
        try:
            while to_start > 0 or running:
                with sigint_deferred():  # raised once every trial asked for is in `running`
                    while to_start > 0 and (not running or len(pending) < concurrency):
                        trial = study.ask()
                        running[trial.number] = (trial, [])
                        heartbeats.beat(trial)
                        values = suggest(trial, space)
                        for condition in range(len(spec.conditions)):
                            for seed in spec.seed_range():
                                ref = submit(run_condition_seed, spec, values, condition, seed)
                                pending[ref] = (trial.number, condition, seed)
                        to_start -= 1
                done, _ = wait_any(list(pending))
                with sigint_deferred():  # raised once the finished trials are told
                    for ref in done:
                        number, condition, seed = pending.pop(ref)
                        trial, episodes = running[number]
                        # a Ray task that died
                        lost = partial(EpisodeOutcome.failed, seed, condition=condition)
                        episodes.append(get(ref, lost))
                        if len(episodes) < per_trial:
                            continue
                        outcome = score_trial(spec, episodes)
                        tell(study, trial, outcome, max_plan_ms)
                        del running[number]
                        heartbeats.stop(trial)
                        finished += 1
                        if on_trial is not None:
                            on_trial(Progress(finished, target, outcome))
        except KeyboardInterrupt:
            # a second Ctrl-C does not cut the failing of the running trials short
            with sigint_deferred():
                cancel(list(pending))
                for trial, _ in running.values():
                    trial.set_user_attr("failure", "interrupted")
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
            raise


BASELINE_ATTR = "baseline"
"""User attribute set on the trial that ran the pair's current defaults."""


def enqueue_defaults(study: Any, space: list[Param], configs: dict[ConfigKind, Config]) -> None:
    """Queue the current defaults (the configs' values of the searched fields) as the next trial.

    Called for a new study, so that its trial 0 measures the settings a tune starts from: the report
    then says what the best trial gained over them (the "before" of a before/after), and the best
    trial is never worse than the defaults. A default outside a --params range is still run as is.
    """
    defaults = {param.name: getattr(configs[param.kind], param.field) for param in space}
    with warnings.catch_warnings():  # optuna warns that an out-of-range default is used as given
        warnings.simplefilter("ignore")
        study.enqueue_trial(defaults, user_attrs={BASELINE_ATTR: True}, skip_if_exists=True)


def is_baseline(trial: Any) -> bool:
    """Whether `trial` is the one `enqueue_defaults` queued."""
    return bool(trial.user_attrs.get(BASELINE_ATTR))


def baseline_trial(study: Any) -> Any | None:
    """The completed trial that ran the defaults, or None (an older study, or it failed)."""
    optuna = import_optuna()
    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    return next((trial for trial in complete if is_baseline(trial)), None)


def is_feasible(trial: Any) -> bool:
    """Whether the trial met --max-plan-ms (always, without it)."""
    return all(value <= 0 for value in constraint_of(trial))


def ranked_trials(study: Any, objective: Objective) -> list[Any]:
    """Completed trials, feasible ones first, each group from best to worst."""
    optuna = import_optuna()
    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    sign = -1.0 if objective.direction == "maximize" else 1.0
    return sorted(
        complete, key=lambda trial: (not is_feasible(trial), sign * trial.value, trial.number)
    )


def best_trial(study: Any, objective: Objective) -> Any | None:
    """The best feasible completed trial, or None when there is none."""
    ranked = ranked_trials(study, objective)
    return ranked[0] if ranked and is_feasible(ranked[0]) else None
