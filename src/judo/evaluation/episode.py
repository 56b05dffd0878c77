"""Closed-loop episodes: a controller drives a simulated plant, optionally with planning latency.

An episode is the one closed-loop step (`judo.loop.closed_loop.ClosedLoop.step`) repeated for
`duration` seconds of sim time: every 1/control_freq of sim time the controller plans from the
plant's reading. Without latency the new plan drives the plant at once. With latency the plant keeps
running on the previous plan while the new one is computed, and the new plan takes effect `latency`
seconds of sim time after the state it was planned from, as on a real robot; the controller cannot
start its next plan before the current one is done. Everything is seeded, so an episode with a fixed
(or no) latency is reproducible bit for bit; "measured" latency uses each update's wall time and so
varies from run to run.
"""

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import numpy as np

from judo.core.configuration.config import require
from judo.core.estimator import Estimator
from judo.core.planner import Planner
from judo.core.task import EpisodeLog, Task
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import PlanRecord, Recorder, StepRecord
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem
from judo.loop.timing import Latency, check_latency
from judo.safety.config import SafetyConfig
from judo.safety.feasibility import RolloutScreen
from judo.safety.serve_filter import safety_guard

__all__ = [
    "EpisodeLogRecorder",
    "EpisodeOutcome",
    "EpisodeResult",
    "episode_failure",
    "run_episode",
    "step_reward",
]

T = TypeVar("T")


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
        limit_hits: with [safety] limits, the serve filter's hits by limit ({}
            without); "limit_hits" in `metrics`
            is their total. no_feasible: planning iterations in which no rollout kept the limits.
    """

    seed: int
    log: EpisodeLog
    rewards: np.ndarray
    metrics: dict[str, float]
    update_ms: np.ndarray
    latency_s: np.ndarray
    failed_updates: int
    divergences: int
    limit_hits: dict[str, int] = field(default_factory=dict)
    no_feasible: int = 0


class EpisodeLogRecorder:
    """Records an episode's plant steps into an EpisodeLog of `num_steps` rows, with each step's
    reward.

    Attributes:
        log: times (S,), states (S, nq + nv), controls (S, nu), sensors (S, nsensordata).
        rewards: (S,) the task's reward of each step alone (see `step_reward`).
        steps: rows filled so far.
    """

    def __init__(
        self, task: Task, sim_model_sizes: tuple[int, int, int, int], num_steps: int
    ) -> None:
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
    safety: SafetyConfig | None = None,
) -> EpisodeResult:
    """Drive the simulated plant `system` with `controller` for `duration` seconds of sim time.

    Args:
        controller: a Planner; plans on its own task instance; seed it (make_controller(...,
            seed=...)) for a reproducible episode. Its plan is reset first.
        system: the plant, from `MujocoSystem.from_task(controller.task, seed)` at its start state,
            or a `SensedSystem` around it (rehearsed sensing: the controller sees only the measured
            sensors).
        duration: seconds of sim time; the episode is round(duration / plant timestep) steps.
        latency: seconds of sim time between a plan's state and its taking effect, or "measured".
        seed: recorded in the result.
        on_update: called after each control update with the plant time, e.g. to advance a progress
            bar.
        recorders: more recorders of every plan and step (e.g. a dataset writer), after the episode
            log.
        estimator: between the reading and the plan (needed when the plant serves only sensors). The
            log and the metrics hold the plant's true state either way.
        safety: the owner's limits (judo.safety): planned within and filtered at serve time; None
            for none.
    """
    require(0 < duration < np.inf, f"duration must be positive and finite, got {duration}")
    check_latency(latency)
    num_steps = max(1, round(duration / system.timestep))
    model = system.task.sim_model
    # controls: what is served
    sizes = (model.nq, model.nv, controller.task.command_size, model.nsensordata)
    episode_log = EpisodeLogRecorder(controller.task, sizes, num_steps)
    # the serve filter of the limits, and a Controller's rollout screen
    guard = safety_guard(controller, safety)
    loop = ClosedLoop(
        controller,
        system,
        latency=latency,
        recorders=[episode_log, *recorders],
        estimator=estimator,
        guard=guard,
    )
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
    hits = {} if guard is None else dict(guard.counts)
    if guard is not None:
        metrics["limit_hits"] = float(sum(hits.values()))
    # what `safety_guard` set as the planner's `limits`
    screen = None if guard is None else guard.screen
    no_feasible = screen.no_feasible if isinstance(screen, RolloutScreen) else 0
    return EpisodeResult(
        seed=seed,
        log=log,
        rewards=rewards,
        metrics=metrics,
        update_ms=np.array(loop.update_ms),
        latency_s=np.array(loop.latency_s),
        failed_updates=loop.failed_updates,
        divergences=loop.divergences,
        limit_hits=hits,
        no_feasible=no_feasible,
    )


def step_reward(task: Task, log: EpisodeLog, step: int, metadata: dict) -> float:
    """The task's reward of plant step `step` of `log` alone, as a batch of one rollout of one
    step."""
    row = slice(step, step + 1)
    reward = task.reward(
        log.states[None, row],
        log.sensors[None, row],
        log.controls[None, row],
        task.config,
        metadata,
    )
    return float(np.asarray(reward, dtype=float).reshape(-1)[0])


def unserved_line(failed_updates: int, num_updates: int, policy: bool, where: str) -> str | None:
    """The loud line for `where` ("seed 3", "2 episodes") when every one of its `num_updates`
    control updates failed, so every action served was the task's safe action; None when at least
    one update worked."""
    if num_updates == 0 or failed_updates < num_updates:
        return None
    what = "non-finite actions" if policy else "no finite reward"
    planner = "policy" if policy else "optimizer"
    return (
        f"warning: {where}: every one of its {num_updates} control updates gave {what}, so "
        "every action served was "
        f"the task's safe action; these figures measure the safe action, not the {planner}"
    )


def episode_failure(result: EpisodeResult, failed_updates_fail: bool = True) -> str | None:
    """Why an episode's numbers cannot be used, or None: its plant diverged (and was reset), a
    metric is not finite, or (with `failed_updates_fail`) a control update failed.

    A failed update (no finite reward, or a policy's non-finite action) left the plant on the task's
    safe action until the next update, so the episode's metrics measure the controller and the safe
    action together: by default that fails the episode, as tune needs, since a trial's settings are
    written as others' defaults and a score the safe action earned is not theirs. collect keeps such
    episodes (`failed_updates_fail=False`): a dataset episode records what the plant did and which
    action was served, it counts them and says so at the end, and its --strict exits 1 for them, as
    evaluate reports each seed's failed updates and --strict exits 1.
    """
    if result.divergences:
        return f"seed {result.seed}: the simulation diverged {result.divergences} times"
    if failed_updates_fail and result.failed_updates:
        return f"seed {result.seed}: {result.failed_updates} control updates had no finite reward"
    bad = [name for name, value in result.metrics.items() if not math.isfinite(value)]
    if bad:
        return f"seed {result.seed}: non-finite {', '.join(bad)}"
    return None


@dataclass
class EpisodeOutcome(Generic[T]):
    """One seeded episode as a command gets it back, from a Ray task or run here: its figures, or
    why it failed.

    Attributes:
        condition: which of the command's episode settings it ran under (tune's conditions; 0
            elsewhere).
        seed: the episode's seed.
        metrics: the episode's metrics ({} when it failed before finishing).
        update_ms: (num_updates,) wall time of each control update, in milliseconds.
        failure: why the episode failed (`episode_failure`, an exception, a Ray task that died), or
            None.
        failed_updates: control updates that failed, so that the task's safe action was served.
        episode: what the command keeps of it besides the figures (evaluate its EpisodeResult, log
            included; collect its recorded EpisodeArrays); None when it failed, and for tune.
    """

    condition: int
    seed: int
    metrics: dict[str, float]
    update_ms: np.ndarray
    failure: str | None = None
    failed_updates: int = 0
    episode: T | None = None

    @classmethod
    def of(
        cls, result: EpisodeResult, episode: T | None, failure: str | None, condition: int = 0
    ) -> "EpisodeOutcome[T]":
        """The outcome of a finished episode `result`: its figures, with `episode` unless `failure`
        is given."""
        kept = episode if failure is None else None
        update_ms = np.asarray(result.update_ms)
        return cls(
            condition, result.seed, result.metrics, update_ms, failure, result.failed_updates, kept
        )

    @classmethod
    def failed(cls, seed: int, reason: str, condition: int = 0) -> "EpisodeOutcome[T]":
        """The outcome of an episode that did not finish (an exception, or its Ray task died), with
        the reason."""
        return cls(condition, seed, {}, np.zeros(0), reason)

    @property
    def num_updates(self) -> int:
        """How many control updates the episode ran."""
        return len(self.update_ms)
