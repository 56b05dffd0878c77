"""Closed-loop episodes: a controller drives a simulated plant, optionally with planning latency.

An episode is the one closed-loop step (`judo.loop.closed_loop.ClosedLoop.step`) repeated for
`duration` seconds of sim time: every 1/control_freq of sim time the controller plans from the plant's
reading. Without latency the new plan drives the plant at once. With latency the plant keeps running on
the previous plan while the new one is computed, and the new plan takes effect `latency` seconds of sim
time after the state it was planned from, as on a real robot; the controller cannot start its next plan
before the current one is done. Everything is seeded, so an episode with a fixed (or no) latency is
reproducible bit for bit; "measured" latency uses each update's wall time and so varies from run to run.
"""

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from judo.core.config import require
from judo.core.estimator import Estimator
from judo.core.planner import Planner
from judo.core.task import EpisodeLog, Task
from judo.loop.closed_loop import ClosedLoop, Latency, check_latency
from judo.loop.records import PlanRecord, Recorder, StepRecord
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem

__all__ = ["EpisodeLogRecorder", "EpisodeResult", "Latency", "run_episode", "step_reward"]


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


class EpisodeLogRecorder:
    """Records an episode's plant steps into an EpisodeLog of `num_steps` rows, with each step's reward.

    Attributes:
        log: times (S,), states (S, nq + nv), controls (S, nu), sensors (S, nsensordata).
        rewards: (S,) the task's reward of each step alone (see `step_reward`).
        steps: rows filled so far.
    """

    def __init__(self, task: Task, sim_model_sizes: tuple[int, int, int, int], num_steps: int) -> None:
        nq, nv, nu, nsensordata = sim_model_sizes
        self.task = task
        self.log = EpisodeLog(
            times=np.zeros(num_steps),
            states=np.zeros((num_steps, nq + nv)),
            controls=np.zeros((num_steps, nu)),
            sensors=np.zeros((num_steps, nsensordata)),
        )
        self.rewards = np.zeros(num_steps)
        self.steps = 0

    def on_plan(self, record: PlanRecord) -> None:
        """Plans are not part of the log."""

    def on_step(self, record: StepRecord) -> None:
        """Fill the next row with the step's reading, action and reward."""
        row, log = self.steps, self.log
        log.times[row] = record.time
        log.states[row] = record.state
        log.controls[row] = record.action
        log.sensors[row] = record.sensors
        self.rewards[row] = step_reward(self.task, log, row, record.metadata)
        self.steps += 1


def run_episode(
    controller: Planner,
    system: "MujocoSystem | SensedSystem",
    duration: float,
    latency: Latency = 0.0,
    seed: int = 0,
    on_update: Callable[[float], None] | None = None,
    recorders: Iterable[Recorder] = (),
    estimator: Estimator | None = None,
) -> EpisodeResult:
    """Drive the simulated plant `system` with `controller` for `duration` seconds of sim time.

    Args:
        controller: a Planner; plans on its own task instance; seed it (make_controller(..., seed=...)) for a
            reproducible episode. Its plan is reset first.
        system: the plant, from `MujocoSystem.from_task(controller.task, seed)` at its start state, or a
            `SensedSystem` around it (rehearsed sensing: the controller sees only the measured sensors).
        duration: seconds of sim time; the episode is round(duration / plant timestep) steps.
        latency: seconds of sim time between a plan's state and its taking effect, or "measured".
        seed: recorded in the result.
        on_update: called after each control update with the plant time, e.g. to advance a progress bar.
        recorders: more recorders of every plan and step (e.g. a dataset writer), after the episode log.
        estimator: between the reading and the plan (needed when the plant serves only sensors). The log
            and the metrics hold the plant's true state either way.
    """
    require(0 < duration < np.inf, f"duration must be positive and finite, got {duration}")
    check_latency(latency)
    num_steps = max(1, round(duration / system.timestep))
    model = system.task.sim_model
    sizes = (model.nq, model.nv, controller.task.command_size, model.nsensordata)  # controls: what is served
    episode_log = EpisodeLogRecorder(controller.task, sizes, num_steps)
    loop = ClosedLoop(controller, system, latency=latency, recorders=[episode_log, *recorders], estimator=estimator)
    loop.restart()
    updates = 0
    for _ in range(num_steps):
        now = loop.reading.time if loop.reading is not None else 0.0
        loop.step()
        if on_update is not None and len(loop.update_ms) > updates:
            updates = len(loop.update_ms)
            on_update(now)
    log, rewards = episode_log.log, episode_log.rewards
    metrics = {**system.task.metrics(log), "mean_reward": float(rewards.mean())}
    return EpisodeResult(
        seed=seed,
        log=log,
        rewards=rewards,
        metrics=metrics,
        update_ms=np.array(loop.update_ms),
        latency_s=np.array(loop.latency_s),
        failed_updates=loop.failed_updates,
        divergences=loop.divergences,
    )


def step_reward(task: Task, log: EpisodeLog, step: int, metadata: dict) -> float:
    """The task's reward of plant step `step` of `log` alone, as a batch of one rollout of one step."""
    row = slice(step, step + 1)
    reward = task.reward(log.states[None, row], log.sensors[None, row], log.controls[None, row], task.config, metadata)
    return float(np.asarray(reward, dtype=float).reshape(-1)[0])


def unserved_line(failed_updates: int, num_updates: int, policy: bool, where: str) -> str | None:
    """The loud line for `where` ("seed 3", "2 episodes") when every one of its `num_updates` control updates
    failed, so every action served was the task's safe action; None when at least one update worked."""
    if num_updates == 0 or failed_updates < num_updates:
        return None
    what = "non-finite actions" if policy else "no finite reward"
    planner = "policy" if policy else "optimizer"
    return (
        f"warning: {where}: every one of its {num_updates} control updates gave {what}, so every action served was "
        f"the task's safe action; these figures measure the safe action, not the {planner}"
    )
