"""One collect episode, run as a Ray task: the one seeded episode runner with an EpisodeRecorder on
its closed loop.

The episode is exactly evaluate's seed `seed` (`judo.evaluation.seeded.run_seeded_episode`); the
recorder gets every plan and step from the one closed-loop step
(`judo.loop.closed_loop.ClosedLoop`).
"""

from judo.core.planner_view import AppPlanner
from judo.core.policies.policy_controller import PolicyController
from judo.core.rollouts.backend import RolloutBackend
from judo.evaluation.episode import EpisodeOutcome, episode_failure
from judo.evaluation.seeded import (
    EpisodeSpec,
    configs_in_force,
    failure_reason,
    planning_model,
    run_policy_episode,
    run_seeded_episode,
    run_side_by_side,
)
from judo.loop.system import MujocoSystem
from judo.recording.dataset import EpisodeArrays
from judo.recording.recorder import EpisodeRecorder, PolicyServedRecorder


def collect_group(
    spec: EpisodeSpec, seeds: list[int], traces: bool = False
) -> list[EpisodeOutcome[EpisodeArrays]]:
    """`collect_episode` of each seed: one after the other, or with more than one seed on the warp
    backend, side by side with their rollouts one batch per planning cycle (collect
    --episodes-per-batch); never raises."""
    if len(seeds) == 1 or spec.backend != "warp":
        return [collect_episode(spec, seed, traces) for seed in seeds]
    try:
        from judo.core.rollouts.warp_rollout import WarpRollout

        with WarpRollout(planning_model(spec)) as backend:
            return run_side_by_side(
                backend, seeds, lambda seed, slot: collect_episode(spec, seed, traces, slot)
            )
    except Exception as err:  # the backend itself failed: every seed of the group failed
        return [EpisodeOutcome.failed(seed, failure_reason(err)) for seed in seeds]


def collect_episode(
    spec: EpisodeSpec, seed: int, traces: bool = False, backend: RolloutBackend | None = None
) -> EpisodeOutcome[EpisodeArrays]:
    """Run and record seed `seed`'s episode, each plan's traces too with `traces` (collect
    --traces), rolling out on `backend` (built from `spec.backend` when None); never raises: a
    failure comes back with its reason. An episode with failed control updates is kept
    (`episode_failure`'s `failed_updates_fail=False`), their count with it."""
    made: list[tuple[EpisodeRecorder, MujocoSystem]] = []

    def plans(planner: AppPlanner, system: MujocoSystem) -> list[EpisodeRecorder]:
        made.append((EpisodeRecorder.for_loop(planner, system.task, traces), system))
        return [made[-1][0]]

    def served(controller: PolicyController, system: MujocoSystem) -> list[EpisodeRecorder]:
        made.append((PolicyServedRecorder.for_policy(controller, system.task, traces), system))
        return [made[-1][0]]

    try:
        if spec.policy is None:
            result = run_seeded_episode(spec, seed, plans, backend=backend)
        # collect --policy: the policy drives; its expert MPC labels the states it is served from
        else:
            result = run_policy_episode(spec, seed, configs_in_force(spec), served)
        failure = episode_failure(result, failed_updates_fail=False)
        if failure is not None:
            return EpisodeOutcome.of(result, None, failure)
        recorder, system = made[0]
        episode = recorder.episode(
            seed, result.rewards, result.metrics, system.task.success(result.metrics)
        )
        return EpisodeOutcome.of(result, episode, None)
    except Exception as err:  # a user's task may raise anything; the run goes on
        return EpisodeOutcome.failed(seed, failure_reason(err))
