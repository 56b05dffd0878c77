"""Closed-loop episodes: a controller drives a simulated plant, optionally with planning latency.

Every 1/control_freq of sim time the controller plans from the plant's current state. Without
latency the new plan drives the plant at once. With latency the plant keeps running on the previous
plan while the new one is computed, and the new plan takes effect `latency` seconds of sim time after
the state it was planned from, as on a real robot; the controller cannot start its next plan before
the current one is done. Everything is seeded, so an episode with a fixed (or no) latency is
reproducible bit for bit; "measured" latency uses each update's wall time and so varies from run to run.
"""

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.config import require
from judo.core.controller import Controller, NonFiniteKnotsError, NonFiniteRewardError
from judo.core.spline import Spline
from judo.core.task import EpisodeLog, Task
from judo.runtime.system import MujocoSystem, SimulationDiverged

Latency = float | Literal["measured"]
"""Planning latency: seconds of sim time (0 for none), or "measured" for each update's wall time."""

PLANT_STREAM = 0x706C616E74
"""Second word of the plant's seed sequence, keeping its stream apart from the controller's generators."""


@dataclass
class EpisodeResult:
    """What one closed-loop episode produced.

    Attributes:
        seed: the seed of the controller's and the plant's generators.
        log: the plant's trajectory, one row per plant step (S steps).
        rewards: (S,) the task's reward of each plant step alone (a one-step rollout of the logged
            state, sensors and control), so its mean is comparable across optimizers.
        metrics: the task's `metrics(log)` plus "mean_reward", the mean of `rewards`.
        update_ms: (num_updates,) wall time of each control update in milliseconds.
        latency_s: (num_updates,) sim-time delay after which each update's plan took effect.
        failed_updates: updates whose rollouts all scored NaN or -inf (the previous plan was kept).
        divergences: times the plant's simulation blew up and was reset.
    """

    seed: int
    log: EpisodeLog
    rewards: np.ndarray
    metrics: dict[str, float]
    update_ms: np.ndarray
    latency_s: np.ndarray
    failed_updates: int
    divergences: int


def make_plant_task(controller: Controller, seed: int) -> Task:
    """A second instance of the controller's task class to serve as the plant, sharing its config.

    The class must be constructible with no arguments, as every registered task is.

    Its `rng` is seeded from `seed` (on a stream apart from the controller's) and it is reset, so the
    plant starts from the task's randomised start state, the same one for the same seed.
    """
    plant = type(controller.task)()  # type: ignore[call-arg]  (registered tasks take no arguments)
    plant.config = controller.task.config
    plant.rng = np.random.default_rng([seed, PLANT_STREAM])
    plant.reset()
    return plant


def run_episode(
    controller: Controller,
    plant_task: Task,
    duration: float,
    latency: Latency = 0.0,
    seed: int = 0,
    on_update: Callable[[float], None] | None = None,
) -> EpisodeResult:
    """Drive `plant_task`'s simulation with `controller` for `duration` seconds of sim time.

    Args:
        controller: plans on its own task instance; seed it (make_controller(..., seed=...)) for a
            reproducible episode. Its plan is reset first.
        plant_task: the plant, e.g. from `make_plant_task`, already reset to its start state.
        duration: seconds of sim time; the episode is round(duration / plant timestep) steps.
        latency: seconds of sim time between a plan's state and its taking effect, or "measured".
        seed: recorded in the result.
        on_update: called after each control update with the plant time, e.g. to advance a progress bar.
    """
    require(0 < duration < np.inf, f"duration must be positive and finite, got {duration}")
    if latency != "measured":
        require(0 <= latency < np.inf, f"latency must be at least 0 s and finite, got {latency}")
    system = MujocoSystem(plant_task)
    controller.reset()
    num_steps = max(1, round(duration / system.timestep))
    period = 1.0 / controller.config.control_freq
    tolerance = 1e-9
    sim_model = plant_task.sim_model
    log = EpisodeLog(
        times=np.zeros(num_steps),
        states=np.zeros((num_steps, sim_model.nq + sim_model.nv)),
        controls=np.zeros((num_steps, sim_model.nu)),
        sensors=np.zeros((num_steps, sim_model.nsensordata)),
    )
    rewards = np.zeros(num_steps)
    warm_start_action = controller.action(0.0)  # what the plant holds until the first plan takes effect
    active_plan: Spline | None = None
    pending: list[tuple[float, Spline]] = []  # (time it takes effect, plan), in order
    next_plan_time = plant_task.data.time
    update_ms: list[float] = []
    latency_s: list[float] = []
    failed_updates = divergences = 0

    reading = system.read_state()
    for step in range(num_steps):
        now = reading.time
        if now >= next_plan_time - tolerance:
            started = time.perf_counter()
            try:
                plan = controller.update_action(reading.state, now, reading.metadata)
            except (NonFiniteRewardError, NonFiniteKnotsError):  # the previous plan stays in force
                plan = None
                failed_updates += 1
            wall = time.perf_counter() - started
            delay = wall if latency == "measured" else float(latency)
            update_ms.append(1e3 * wall)
            latency_s.append(delay)
            if plan is not None:
                pending.append((now + delay, plan))
            # The next tick of the control clock, or at once when this update overran it.
            next_plan_time = max(next_plan_time + period, now + delay)
            if on_update is not None:
                on_update(now)
        while pending and pending[0][0] <= now + tolerance:
            active_plan = pending.pop(0)[1]
        action = warm_start_action if active_plan is None else active_plan(now)
        system.apply(action)
        try:
            system.step()
        except SimulationDiverged:
            divergences += 1
        reading = system.read_state()
        log.times[step] = reading.time
        log.states[step] = reading.state
        log.controls[step] = action
        log.sensors[step] = plant_task.data.sensordata
        rewards[step] = step_reward(controller.task, log, step, reading.metadata)

    metrics = {**plant_task.metrics(log), "mean_reward": float(rewards.mean())}
    return EpisodeResult(
        seed=seed,
        log=log,
        rewards=rewards,
        metrics=metrics,
        update_ms=np.array(update_ms),
        latency_s=np.array(latency_s),
        failed_updates=failed_updates,
        divergences=divergences,
    )


def step_reward(task: Task, log: EpisodeLog, step: int, metadata: dict) -> float:
    """The task's reward of plant step `step` of `log` alone, as a batch of one rollout of one step."""
    row = slice(step, step + 1)
    reward = task.reward(log.states[None, row], log.sensors[None, row], log.controls[None, row], task.config, metadata)
    return float(np.asarray(reward, dtype=float).reshape(-1)[0])
