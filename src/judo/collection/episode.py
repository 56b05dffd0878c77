"""One collect episode: evaluate's closed-loop runner with recorders attached, run as a Ray task.

`record_episode` feeds recorders from today's `run_episode` (judo.evaluation.episode): each plan is
read off the controller right after its update (`on_update`), and each step's mocap positions off the
plant right after its step (the plant task's `post_sim_step`, which is the last thing before the
reading). When the closed-loop step (`judo.runtime.closed_loop.ClosedLoop`) lands, it calls the
recorders itself and this adapter goes.
"""

import math
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from judo.collection.dataset import EpisodeArrays
from judo.collection.recorder import EpisodeRecorder
from judo.core.config import Config
from judo.core.controller import Controller
from judo.core.errors import JudoError
from judo.core.task import Task
from judo.evaluation.episode import EpisodeResult, Latency, make_plant_task, run_episode
from judo.runtime.records import PlanRecord, Recorder, StepRecord

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


def configs_in_force(spec: CollectSpec) -> dict[str, Config]:
    """{"controller", "optimizer", "task"}: the task's registered configs with `spec.values` applied."""
    from judo.tuning.space import apply_values, default_configs

    load_config_once(spec.config_file)
    return apply_values(default_configs(spec.task, spec.optimizer), spec.values)


def record_episode(
    controller: Controller, plant: Task, duration: float, latency: Latency, seed: int, recorders: list[Recorder]
) -> EpisodeResult:
    """`run_episode(controller, plant, duration, latency, seed)`, calling each recorder's on_plan and on_step
    in the order the plans and steps happened."""
    plans: list[tuple[int, PlanRecord]] = []  # (update index, record with update_ms and takes_effect to fill)
    previous_knots: list[Any] = [None]
    updates: list[float] = []

    def on_update(now: float) -> None:
        knots = controller.nominal_knots
        if knots is not None and knots is not previous_knots[0]:  # a failed update keeps the old array
            finite = controller.rewards[np.isfinite(controller.rewards)]
            best = float(finite.max()) if finite.size else -math.inf
            mean = float(finite.mean()) if finite.size else -math.inf
            plans.append((len(updates), PlanRecord(now, now, knots.copy(), 0.0, best, mean)))
        previous_knots[0] = knots
        updates.append(now)

    mocap: list[np.ndarray] = []
    plant_post_step = plant.post_sim_step

    def post_sim_step() -> None:
        plant_post_step()
        mocap.append(plant.data.mocap_pos.copy())

    plant.post_sim_step = post_sim_step  # type: ignore[method-assign]  (this plant instance only)
    try:
        result = run_episode(controller, plant, duration, latency, seed, on_update)
    finally:
        del plant.post_sim_step
    for index, plan in plans:
        plan.update_ms = float(result.update_ms[index])
        plan.takes_effect = plan.time + float(result.latency_s[index])
    log, dt = result.log, float(plant.sim_model.opt.timestep)
    pending = iter(plans)
    upcoming = next(pending, None)
    for step in range(len(log.times)):
        while upcoming is not None and upcoming[1].time <= log.times[step] - dt / 2:
            for recorder in recorders:
                recorder.on_plan(upcoming[1])
            upcoming = next(pending, None)
        metadata = {"mocap_pos": mocap[step]} if step < len(mocap) else {}
        record = StepRecord(float(log.times[step]), log.states[step], log.sensors[step], log.controls[step], metadata)
        for recorder in recorders:
            recorder.on_step(record)
    return result


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
        controller = make_controller(
            spec.task,
            spec.optimizer,
            controller_config=configs["controller"],  # type: ignore[arg-type]
            optimizer_config=configs["optimizer"],  # type: ignore[arg-type]
            num_workers=spec.num_workers,
            seed=seed,
            backend=spec.backend,
        )
        try:
            controller.task.config = configs["task"]
            plant = make_plant_task(controller, seed)
            model = plant.sim_model
            recorder = EpisodeRecorder(model.nq, model.nv, model.nmocap, controller.optimizer.num_nodes, model.nu)
            result = record_episode(controller, plant, spec.duration, spec.latency, seed, [recorder])
        finally:
            controller.close()
        failure = episode_failure(result)
        if failure is not None:
            return EpisodeOutcome(seed, None, failure)
        episode = recorder.episode(seed, result.rewards, result.metrics, plant.success(result.metrics))
        return EpisodeOutcome(seed, episode)
    except JudoError as err:
        return EpisodeOutcome(seed, None, f"{type(err).__name__}: {err}")
    except Exception as err:  # noqa: BLE001  (a user's task may raise anything; the run goes on)
        where = traceback.extract_tb(err.__traceback__)[-1]
        return EpisodeOutcome(seed, None, f"{type(err).__name__}: {err} ({Path(where.filename).name}:{where.lineno})")
