"""The arguments of `python -m judo tune` (`TuneArgs`): the task x optimizer, the metric, the
budget, the conditions each trial is scored under, the sampler, and where the study and its outputs
are stored, with their checks."""

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Literal

import tyro

from judo.cli_shared import check_names, episode_latency
from judo.core.commandline.boundary import check_seed_range
from judo.core.configuration.config import require
from judo.evaluation.sensing import SensingFlags
from judo.loop.timing import Latency
from judo.tuning.conditions import (
    Aggregate,
    Condition,
    ConditionError,
    ConditionsMode,
    check_conditions,
    parse_conditions,
)
from judo.tuning.objective import Direction


@dataclass
class TuneArgs(SensingFlags):
    """Arguments of `python -m judo tune`."""

    task: Annotated[str, tyro.conf.arg(metavar="NAME")]
    """Task to tune, by registered name."""
    optimizer: Annotated[str, tyro.conf.arg(metavar="NAME")]
    """Optimizer to tune, by registered name."""
    metric: Annotated[
        str | None, tyro.conf.arg(metavar="NAME", help_behavior_hint="(default: mean_reward)")
    ] = None
    """The evaluate metric to optimise, averaged over seeds; its direction is the task's
    (lower_is_better)."""
    trials: int = 20
    """Finished trials the study should have; a resumed study runs only the missing ones."""
    seeds: int = 3
    """Episodes per trial and condition, with seeds first_seed to first_seed + seeds - 1."""
    first_seed: int = 0
    """Seed of each condition's first episode: e.g. --first-seed 1000 tunes on seeds an `evaluate`
    of seeds 0 to 999 never sees. Not part of a study's identity (as --seeds is not): a resumed
    study scores its new trials on these seeds."""
    duration: float = 10.0
    """Length of each episode in seconds of sim time."""
    params: Annotated[
        tuple[str, ...],
        tyro.conf.arg(
            metavar="KIND.FIELD[=LOW:HIGH] ...", help_behavior_hint="(default: see above)"
        ),
    ] = ()
    """Parameters to search instead of the default space, e.g. optimizer.temperature
    controller.horizon task.w_position; LOW:HIGH replaces the slider range. KIND is controller,
    optimizer or task."""
    fix: Annotated[
        tuple[str, ...],
        tyro.conf.arg(metavar="KIND.FIELD=VALUE ...", help_behavior_hint="(optional)"),
    ] = ()
    """Fields pinned for every trial (and left out of the space), e.g. optimizer.num_rollouts=64."""
    max_plan_ms: Annotated[
        float | None, tyro.conf.arg(metavar="MS", help_behavior_hint="(optional)")
    ] = None
    """Best quality at a median control update of at most this: slower trials are kept but marked
    infeasible."""
    direction: Annotated[
        Direction | None,
        tyro.conf.arg(metavar="{maximize,minimize}", help_behavior_hint="(default: the metric's)"),
    ] = None
    """Override the metric's direction (for a metric of your own task that is better lower)."""
    conditions: Annotated[
        tuple[str, ...],
        tyro.conf.arg(
            metavar="NAME=V1,V2,... ...", help_behavior_hint="(default: the task's check set)"
        ),
    ] = ()
    """Episode settings every trial is scored under: latency_ms (fixed planning latency) and
    control_freq (Hz), e.g. latency_ms=0,25,50 control_freq=20,50. Crossed: every combination (here
    6 conditions); with --conditions-mode listed the i-th values of each name make the i-th
    condition. Default: control_freq 20 and the task's own rate, crossed with latency_ms 0 and 25
    (50 for leap_cube, leap_cube_down, fr3_pick), unless --latency or --latency-ms picks a single
    condition."""
    conditions_mode: ConditionsMode = "crossed"
    """How --conditions' lists combine: crossed (every combination) or listed (paired by position,
    equal lengths)."""
    aggregate: Aggregate = "mean"
    """How the conditions' metrics (each a mean over seeds) become the trial's value: their mean,
    the worst, or cvar (the mean of the worst --cvar-alpha fraction of conditions)."""
    cvar_alpha: float = 0.5
    """The fraction of worst conditions --aggregate cvar averages (at least one condition)."""
    latency: Literal["none", "measured"] = "none"
    """Planning latency in the episodes, as for evaluate; measured runs one condition at the task's
    rate (or each --conditions control_freq)."""
    latency_ms: Annotated[
        float | None, tyro.conf.arg(metavar="MS", help_behavior_hint="(optional)")
    ] = None
    """Fixed planning latency in milliseconds of sim time, as for evaluate, instead of --latency:
    one condition at the task's rate (or each --conditions control_freq); same as --conditions
    latency_ms=MS."""
    sampler: Literal["tpe", "cmaes", "random", "grid"] = "tpe"
    """Optuna sampler: TPE, CMA-ES, random search, or a grid of 3 values per parameter."""
    seed: int = 0
    """Seed of the sampler."""
    workers: Annotated[
        int | None, tyro.conf.arg(metavar="N", help_behavior_hint="(default: one per core)")
    ] = None
    """Trials run at once, each on one rollout thread (the CPUs of a local Ray; with --address,
    default all the cluster's CPUs)."""
    address: Annotated[
        str | None, tyro.conf.arg(metavar="ADDRESS", help_behavior_hint="(default: a local Ray)")
    ] = None
    """A running Ray cluster: auto (the one `ray start --head` started on this machine) or
    ray://HOST:10001."""
    storage: Annotated[
        str | None, tyro.conf.arg(metavar="URL", help_behavior_hint="(default: sqlite in --out)")
    ] = None
    """Optuna RDB storage URL, e.g. sqlite:///judo-tune.db or postgresql://user:password@host/db."""
    study: Annotated[
        str | None,
        tyro.conf.arg(metavar="NAME", help_behavior_hint="(default: TASK-OPTIMIZER-METRIC)"),
    ] = None
    """Study name; an existing study of that name in the storage is resumed."""
    out: Annotated[
        Path | None,
        tyro.conf.arg(metavar="DIR", help_behavior_hint="(default: tune-TASK-OPTIMIZER)"),
    ] = None
    """Folder for trials.csv, the plots, summary.json and best.toml."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file, as for the app, that registers custom tasks and optimizers and sets per-task
    overrides."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant only, by element name (tune for a plant unlike the
    planning model), e.g. body_mass.pole=0.13; after the --config file's [plant_overrides.TASK]
    (docs/sysid.md)."""

    def validate(self) -> None:
        """Raise a JudoError for an argument out of range or a name that is not registered."""
        check_names([self.task], [self.optimizer])
        require(self.trials >= 1, f"--trials must be at least 1, got {self.trials}")
        require(self.seeds >= 1, f"--seeds must be at least 1, got {self.seeds}")
        check_seed_range(self.first_seed, self.seeds, "--seeds")
        require(self.duration > 0, f"--duration must be positive, got {self.duration}")
        require(
            self.workers is None or self.workers >= 1,
            f"--workers must be at least 1, got {self.workers}",
        )
        require(
            self.max_plan_ms is None or self.max_plan_ms > 0,
            f"--max-plan-ms must be positive, got {self.max_plan_ms}",
        )
        require(
            self.latency_ms is None or self.latency == "none",
            f"give either --latency {self.latency} or --latency-ms {self.latency_ms}, not both",
        )
        require(0 < self.cvar_alpha <= 1, f"--cvar-alpha must be in (0, 1], got {self.cvar_alpha}")
        self.sensing()

    def condition_list(self) -> list[Condition]:
        """The conditions every trial runs: --conditions, or one condition for
        --latency/--latency-ms, or the task's check set. ConditionError for a bad entry, or a
        latency given both ways."""
        conditions = parse_conditions(self.conditions, self.conditions_mode)
        own_latency = self.latency_ms is not None or self.latency == "measured"
        if any(condition.latency_ms is not None for condition in conditions) and own_latency:
            flag = "--latency-ms" if self.latency_ms is not None else "--latency measured"
            raise ConditionError(
                f"give the latency either in --conditions latency_ms=... or by {flag}, not both"
            )
        if self.latency_ms is not None:  # folded into every condition
            return [
                replace(condition, latency_ms=self.latency_ms)
                for condition in conditions or [Condition()]
            ]
        if conditions:
            return conditions
        return [Condition()] if own_latency else check_conditions(self.task)

    def episode_latency(self) -> Latency:
        """The latency `run_episode` takes: seconds, or "measured"."""
        return episode_latency(self.latency, self.latency_ms)

    def out_dir(self) -> Path:
        """--out, or tune-TASK-OPTIMIZER."""
        return self.out or Path(f"tune-{self.task}-{self.optimizer}")

    def storage_url(self) -> str:
        """--storage, or a SQLite file in the output folder."""
        return self.storage or f"sqlite:///{self.out_dir() / 'study.db'}"
