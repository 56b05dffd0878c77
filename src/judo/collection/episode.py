"""One collect episode, run as a Ray task: evaluate's episode runner with an EpisodeRecorder on its closed loop.

The episode is exactly evaluate's seed `seed` (`run_episode` on `MujocoSystem.from_task`); the recorder
gets every plan and step from the one closed-loop step (`judo.runtime.closed_loop.ClosedLoop`).
"""

import math
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from judo.collection.dataset import EpisodeArrays
from judo.collection.recorder import EpisodeRecorder
from judo.core.config import Config
from judo.core.errors import JudoError
from judo.evaluation.episode import EpisodeResult, Latency, run_episode
from judo.runtime.system import MujocoSystem
from judo.tuning.space import Kind

_LOADED_CONFIG_FILES: set[str] = set()
"""--config files already read in this process (a Ray worker runs many episodes)."""


@dataclass(frozen=True)
class CollectSpec:
    """What every episode of a collect run shares.

    Attributes:
        task, optimizer: registered names.
        duration: seconds of sim time per episode.
        latency: seconds of sim time between a plan's reading and its taking effect, or "measured".
        values: config fields changed from the task's defaults, {"controller.horizon": 1.0, "optimizer.sigma": ...}.
        config_file: the user's --config file (read once per process), or None.
        backend: rollout backend, "cpu" or "warp".
        num_workers: rollout threads per episode (1, so that parallel episodes do not fight for cores).
    """

    task: str
    optimizer: str
    duration: float
    latency: Latency = 0.0
    values: dict[str, Any] = field(default_factory=dict)
    config_file: str | None = None
    backend: str = "cpu"
    num_workers: int = 1


@dataclass
class EpisodeOutcome:
    """What one Ray task sends back: the episode, or why it failed."""

    seed: int
    episode: EpisodeArrays | None
    failure: str | None = None


def load_config_once(path: str | None) -> None:
    """Read the user's --config file in this process, once (registering its classes and overrides)."""
    if path is None or path in _LOADED_CONFIG_FILES:
        return
    from judo.core.config_file import load_config

    load_config(path)
    _LOADED_CONFIG_FILES.add(path)


def configs_in_force(spec: CollectSpec) -> dict[Kind, Config]:
    """{"controller", "optimizer", "task"}: the task's registered configs with `spec.values` applied."""
    from judo.tuning.space import apply_values, default_configs

    load_config_once(spec.config_file)
    return apply_values(default_configs(spec.task, spec.optimizer), spec.values)


def episode_failure(result: EpisodeResult) -> str | None:
    """Why an episode is not fit for a dataset (its plant diverged and was reset, a metric is not finite), or None."""
    if result.divergences:
        return f"the simulation diverged {result.divergences} times"
    bad = [name for name, value in result.metrics.items() if not math.isfinite(value)]
    return f"non-finite metrics: {', '.join(bad)}" if bad else None


def collect_episode(spec: CollectSpec, seed: int) -> EpisodeOutcome:
    """Run and record seed `seed`'s episode; never raises: a failure comes back with its reason."""
    from judo.core.registry import make_controller

    try:
        configs = configs_in_force(spec)
        with make_controller(
            spec.task,
            spec.optimizer,
            controller_config=configs["controller"],  # type: ignore[arg-type]
            optimizer_config=configs["optimizer"],  # type: ignore[arg-type]
            num_workers=spec.num_workers,
            seed=seed,
            backend=spec.backend,
        ) as controller:
            controller.task.config = configs["task"]
            system = MujocoSystem.from_task(controller.task, seed)
            model = system.task.sim_model
            recorder = EpisodeRecorder(model.nq, model.nv, model.nmocap, controller.optimizer.num_nodes, model.nu)
            result = run_episode(controller, system, spec.duration, spec.latency, seed, recorders=[recorder])
        failure = episode_failure(result)
        if failure is not None:
            return EpisodeOutcome(seed, None, failure)
        episode = recorder.episode(seed, result.rewards, result.metrics, system.task.success(result.metrics))
        return EpisodeOutcome(seed, episode)
    except JudoError as err:
        return EpisodeOutcome(seed, None, f"{type(err).__name__}: {err}")
    except Exception as err:  # noqa: BLE001  (a user's task may raise anything; the run goes on)
        where = traceback.extract_tb(err.__traceback__)[-1]
        return EpisodeOutcome(seed, None, f"{type(err).__name__}: {err} ({Path(where.filename).name}:{where.lineno})")
