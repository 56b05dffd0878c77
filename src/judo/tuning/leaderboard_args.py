"""The arguments of `python -m judo leaderboard` (`LeaderboardArgs`): the tasks and optimizers
compared, the trial and seed budgets, the protocol folder, Ray, the sampler and the output folder,
with their checks."""

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import tyro

from judo.cli_shared import check_names
from judo.core.commandline.boundary import (
    MAX_SAMPLES,
    MAX_WORKERS,
    check_count,
    check_output_folder,
    check_seed_range,
)
from judo.core.configuration.config import require_between
from judo.core.configuration.registry import get_registered_optimizers


@dataclass
class LeaderboardArgs:
    """Arguments of `python -m judo leaderboard`."""

    tasks: Annotated[tuple[str, ...], tyro.conf.arg(metavar="NAME ...")]
    """Tasks to compare on, by registered name; each needs a protocol file."""
    optimizers: Annotated[
        tuple[str, ...],
        tyro.conf.arg(metavar="NAME ...", help_behavior_hint="(default: every registered one)"),
    ] = ()
    """Optimizers to compare, by registered name."""
    trials: int = 20
    """Trials per task x optimizer (the first runs the optimizer's defaults); a resumed run adds
    only missing ones."""
    seeds: int = 10
    """Fresh seeds (0 to seeds - 1) each tuned setting and the shipped default are validated on."""
    out: Annotated[Path, tyro.conf.arg(metavar="DIR")] = Path("leaderboard")
    """Folder for the outputs and the study database (leaderboard.db) that a rerun resumes."""
    protocols: Annotated[
        Path | None, tyro.conf.arg(metavar="DIR", help_behavior_hint="(optional)")
    ] = None
    """Folder of your own protocol files, TASK.toml, read before the shipped ones
    (docs/optimizers.md)."""
    address: Annotated[
        str | None, tyro.conf.arg(metavar="ADDRESS", help_behavior_hint="(default: a local Ray)")
    ] = None
    """A running Ray cluster: auto (the one `ray start --head` started on this machine) or
    ray://HOST:10001."""
    workers: Annotated[
        int | None, tyro.conf.arg(metavar="N", help_behavior_hint="(default: one per core)")
    ] = None
    """Episodes run at once, each on one rollout thread (the CPUs of a local Ray)."""
    sampler: Literal["tpe", "cmaes", "random"] = "tpe"
    """Optuna sampler of every study."""
    seed: int = 0
    """Seed of the samplers."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file, as for the app, that registers custom tasks and optimizers and sets per-task
    overrides."""

    def optimizer_names(self) -> list[str]:
        """--optimizers without repeats, or every registered optimizer."""
        return list(dict.fromkeys(self.optimizers)) or list(get_registered_optimizers())

    def task_names(self) -> list[str]:
        """--tasks without repeats."""
        return list(dict.fromkeys(self.tasks))

    def validate(self) -> None:
        """Raise a JudoError (one line, listing the valid choices) for an unknown name or a count
        out of range."""
        check_names(self.task_names(), self.optimizer_names())
        check_count("--trials", self.trials, MAX_SAMPLES)
        require_between("--seeds", self.seeds, 1, 10_000)
        check_seed_range(0, self.seeds, "--seeds")
        check_count("--workers", self.workers, MAX_WORKERS)
        check_output_folder("--out", self.out)
