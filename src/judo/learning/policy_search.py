"""Policy search: judo's own CEM tunes a gait policy (judo.tasks.gait_policy) on closed-loop
episodes of a legged task (`GaitProblem`: quadruped_velocity's quadruped, go2_walk's Go2, or
gait_search's g1_stand problem: a balance policy under kicks).

Each iteration draws `commands` velocity commands from the problem's ranges. Every one of the CEM's
`population` candidate parameter rows then walks every command for `episode_seconds` from the
task's start (at a random point of the gait's cycle), all population x commands episodes stepped
together with `mujoco.rollout` on `workers` threads, the policy run between ticks as the low-level
hook runs it (every EVERY steps). A candidate's score is the mean over its commands of the task's
own reward, the objective the MPC plans with (height, uprightness, the trot's foot schedule,
posture, effort, and the command's velocity and yaw rate), so the search teaches the policy what the
MPC would do, without the MPC's sampling noise in the labels that defeated cloning it
(docs/tasks.md).
"""

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.model import STATE_SPEC
from judo.core.rollouts.rollout import RolloutPool
from judo.core.rollouts.stepper import PolicyStepper
from judo.optimizers.cem import CEM, CEMConfig
from judo.tasks.gait import GAITS
from judo.tasks.gait_policy import (
    COMMAND_FEATURES,
    HARMONICS,
    GaitLayout,
    gait_actions,
)
from judo.tasks.quadruped import STANDING_HEIGHT, locomotion_features
from judo.tasks.quadruped_velocity import (
    COMMAND_KEY,
    OBSERVATION_COLUMNS,
    QuadrupedVelocity,
    draw_command,
)
from judo.tasks.unitree import go2

EVERY = 2
"""Physics steps per policy tick: 50 Hz on the 0.01 s timestep of both the quadruped and the Go2
(quadruped_navigate's rate)."""
GO2_COMMAND_RANGE = np.array([[-0.3, 0.8], [-0.3, 0.3], [-0.8, 0.8]])
"""(3, 2) [low, high] of the [vx, vy, yaw rate] commands the Go2's search draws (uniformly): around
go2_walk's default (0.5, 0, 0)."""


@dataclass
class GaitSearchSettings:
    """What one search runs: the CEM's sizes, the episodes each candidate walks, and the seed."""

    iterations: int = 150
    """CEM iterations."""
    population: int = 64
    """Candidate parameter rows per iteration, the current mean included."""
    elites: int = 8
    """Best candidates the CEM's Gaussian is fitted to."""
    commands: int = 12
    """Commands drawn per iteration; every candidate walks each of them."""
    episode_seconds: float = 3.0
    """Sim seconds of each episode, from standing."""
    sigma_min: float = 0.02
    """Smallest std (rad per unit feature) the CEM samples with."""
    sigma_max: float = 0.05
    """Largest std, and the first iteration's."""
    seed: int = 0
    """Seeds the commands, the start phases and the CEM's samples."""
    workers: int = 2
    """Threads stepping the episodes."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for a setting out of range."""
        require_between("--iterations", self.iterations, 1, 100_000)
        require_between("--population", self.population, 2, 100_000)
        require_between("--elites", self.elites, 1, self.population)
        require_between("--commands", self.commands, 1, 10_000)
        require(
            0.1 <= self.episode_seconds <= 60,
            f"--episode-seconds must be 0.1 to 60, got {self.episode_seconds}",
        )
        require(
            0 < self.sigma_min <= self.sigma_max <= 2,
            f"need 0 < --sigma-min <= --sigma-max <= 2, got {self.sigma_min}, {self.sigma_max}",
        )
        require(self.seed >= 0, f"--seed must be at least 0, got {self.seed}")
        require_between("--workers", self.workers, 1, 1024)


def trot_phase_signs() -> np.ndarray:
    """(12,) +1 for the joints of the trot's first diagonal pair (FR, RL), -1 for the other's (FL,
    RR): legs in FR, FL, RR, RL order, three joints each, for both robots."""
    offsets = np.array(GAITS["trot"].offsets)
    return np.repeat(np.where(offsets == 0.0, 1.0, -1.0), 3)


def trot_layout(task: QuadrupedVelocity | go2.Go2Walk, home: np.ndarray) -> GaitLayout:
    """The gait policy's layout on a trotting task's observation (quadruped_velocity.OBSERVATION's
    columns, which go2_walk's shares), around the (12,) `home` targets: the trot's diagonal pairs
    half a cycle apart, feedback on the base's gyro and gravity direction."""
    return GaitLayout(
        home=np.array(home, dtype=float),
        command_columns=OBSERVATION_COLUMNS["command"],
        clock_columns=OBSERVATION_COLUMNS["clock"],
        feedback_columns=OBSERVATION_COLUMNS["gyro_and_gravity"],
        phase_signs=trot_phase_signs(),
        observation_size=task.policy_observation_size(),
    )


def quadruped_gait_layout(task: QuadrupedVelocity) -> GaitLayout:
    """`trot_layout` on quadruped_velocity, around its standing pose."""
    return trot_layout(task, task.home_ctrl)


def go2_gait_layout(task: go2.Go2Walk) -> GaitLayout:
    """`trot_layout` on go2_walk (Unitree's motor order FR, FL, RR, RL x hip, thigh, calf), around
    RISE_POSE (the stand at the 0.30 m target height)."""
    return trot_layout(task, go2.RISE_POSE)


@dataclass
class GaitProblem:
    """What the search needs of a legged task: its layout, start, commands, observation and score.

    Attributes:
        name: the registered task's name.
        task: the task (its planning model is stepped).
        layout: the gait policy's layout on the task's observation.
        start_qpos, start_ctrl: (nq,) and (nu,) the episodes' start (at rest).
        draw: rng -> (3,) a command [vx, vy, yaw rate].
        observe: ((B, 3) commands, (B, nq + nv) states, (B,) times, (B, O) out) -> out.
        reward: ((B, T, nq + nv) states, (B, T, nsensordata) sensors, (B, T, nu) ctrl, (3,)
            command) -> (B,) the task's reward of episodes that all walked `command`.
        fallen_height: the base height (m) under which an episode counts as fallen.
        kicks: the drawn commands' [vx, vy] are also the base's start velocity (m/s, world frame).
        free: (P,) bool, the parameters the CEM tunes (the rest stay at the first mean's), or None:
            all.
        initial: (P,) the first mean, or None: `stepping_in_place`.
    """

    name: str
    task: Any
    layout: GaitLayout
    start_qpos: np.ndarray
    start_ctrl: np.ndarray
    draw: Callable[[np.random.Generator], np.ndarray]
    observe: Callable[..., np.ndarray]
    reward: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    fallen_height: float
    kicks: bool = False
    free: np.ndarray | None = None
    initial: np.ndarray | None = None


def quadruped_problem(task: QuadrupedVelocity | None = None) -> GaitProblem:
    """quadruped_velocity: from the standing pose, commands from its config's ranges, its reward
    with the command as the plant publishes it."""
    task = QuadrupedVelocity() if task is None else task
    config = task.config

    def reward(
        states: np.ndarray, sensors: np.ndarray, ctrl: np.ndarray, command: np.ndarray
    ) -> np.ndarray:
        return task.reward(states, sensors, ctrl, config, {COMMAND_KEY: command})

    return GaitProblem(
        name="quadruped_velocity",
        task=task,
        layout=quadruped_gait_layout(task),
        start_qpos=task.model.key_qpos[0].copy(),
        start_ctrl=task.home_ctrl.copy(),
        draw=lambda rng: draw_command(config, rng),
        observe=lambda commands, states, times, out: task.locomotion_observation(
            commands, states, None, times, out=out
        ),
        reward=reward,
        fallen_height=0.5 * STANDING_HEIGHT,
    )


def go2_problem(task: go2.Go2Walk | None = None) -> GaitProblem:
    """go2_walk: from its start (the crouched stand, keyframe "home", the targets RISE_POSE),
    commands from GO2_COMMAND_RANGE, its reward with the command as its config's
    `velocity_command`."""
    task = go2.Go2Walk(policy_path=None) if task is None else task
    key = mujoco.mj_name2id(task.model, mujoco.mjtObj.mjOBJ_KEY, task.start_key)
    low, high = GO2_COMMAND_RANGE.T

    def reward(
        states: np.ndarray, sensors: np.ndarray, ctrl: np.ndarray, command: np.ndarray
    ) -> np.ndarray:
        config = dataclasses.replace(task.config, velocity_command=np.asarray(command, float))
        return task.reward(states, sensors, ctrl, config)

    return GaitProblem(
        name="go2_walk",
        task=task,
        layout=go2_gait_layout(task),
        start_qpos=task.model.key_qpos[key].copy(),
        start_ctrl=go2.RISE_POSE.copy(),
        draw=lambda rng: rng.uniform(low, high),
        observe=lambda commands, states, times, out: locomotion_features(
            states, task.proprioception, go2.POSTURE, commands, times, out
        ),
        reward=reward,
        fallen_height=go2.FALLEN_HEIGHT,
    )


def stepping_in_place(layout: GaitLayout) -> np.ndarray:
    """(P,) the search's first mean: each hip flexes by up to 0.25 rad and each knee by up to 0.5
    rad in its leg's swing half of the cycle (a half-wave sine), whatever the command: a trot on the
    spot."""
    # max(0, sin p) in [1, cos, sin, cos2, sin2]
    half_wave = np.array([1 / np.pi, 0.0, 0.5, -2 / (3 * np.pi), 0.0])
    weights = np.zeros((layout.num_joints, HARMONICS, COMMAND_FEATURES))
    weights[1::3, :, 0] = 0.25 * half_wave  # hips (abduction, hip, knee per leg)
    weights[2::3, :, 0] = -0.5 * half_wave  # knees bend further (more negative)
    gains = np.zeros((layout.num_joints, len(layout.feedback_columns)))
    return np.concatenate([weights.ravel(), gains.ravel()])


@dataclass
class Iteration:
    """One CEM iteration's figures, for the progress bar and the history."""

    index: int
    mean_reward: float
    """The current mean's reward (candidate 0), averaged over this iteration's commands."""
    best_reward: float
    falls: float
    """Share of the mean's episodes that fell (trunk below half its standing height)."""
    seconds: float


@dataclass
class GaitSearchResult:
    """What a search found: the best iteration's mean, and every iteration's figures.

    Attributes:
        parameters: (P,) the mean that scored best (an iteration's candidate 0, scored on that
            iteration's commands), not the last one, which a late noisy update may have made worse.
        best_index: the iteration it was scored in.
        history: every finished iteration's figures.
        interrupted: whether Ctrl-C ended the search early (after at least one iteration).
    """

    parameters: np.ndarray
    best_index: int
    history: list[Iteration]
    interrupted: bool = False


class GaitEpisodes:
    """Steps B closed-loop episodes of a `GaitProblem`'s task at once, each with its own gait policy
    parameters, on a `PolicyStepper` block by block on a `RolloutPool`'s workers (its threads and
    MjData kept for every tick of every run; `close` ends them)."""

    def __init__(self, problem: GaitProblem, workers: int) -> None:
        self.problem, self.layout, self.model = problem, problem.layout, problem.task.model
        self.pool = RolloutPool(self.model, workers)
        self.stepper = PolicyStepper(
            self.model, self.model.nu, EVERY, observation_size=self.layout.observation_size
        )
        data = mujoco.MjData(self.model)
        data.qpos[:] = problem.start_qpos
        data.ctrl[:] = problem.start_ctrl
        mujoco.mj_forward(self.model, data)
        self._start = np.zeros(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, data, self._start, STATE_SPEC)

    def run(
        self, parameters: np.ndarray, commands: np.ndarray, start_times: np.ndarray, seconds: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Walk (B, P) `parameters` rows on (B, 3) `commands` from the start at (B,) sim
        `start_times` for `seconds`; returns each tick's (B, ticks, nq + nv) states, (B, ticks,
        nsensordata) sensors and (B, ticks, nu) ctrl."""
        model, batch, stepper, layout = self.model, len(parameters), self.stepper, self.layout
        ticks = max(1, round(seconds / (EVERY * model.opt.timestep)))
        stepper.start(batch, ticks * EVERY, self._start)
        stepper.current[:, 0] = start_times
        if self.problem.kicks:  # FULLPHYSICS rows: time, qpos, qvel, ...
            stepper.current[:, 1 + model.nq : 3 + model.nq] = commands[:, :2]
        states = np.zeros((batch, ticks, model.nq + model.nv))
        sensors = np.zeros((batch, ticks, model.nsensordata))
        ctrl = np.zeros((batch, ticks, model.nu))
        observe_rows = self.problem.observe

        def observe(
            rows: slice, start: int, current: np.ndarray, previous: np.ndarray
        ) -> np.ndarray:
            out = stepper.observations[rows]  # written in place: no temporaries per tick
            return observe_rows(commands[rows], current[:, 1:], current[:, 0], out)

        def act(rows: slice, observations: np.ndarray) -> np.ndarray:
            # (B, 1, nu), held for the tick
            return gait_actions(parameters[rows], observations, layout)[:, None]

        # each tick keeps its last step's row
        def record(rows: slice, start: int, stop: int) -> None:
            tick = start // EVERY
            ctrl[rows, tick] = stepper.inputs[EVERY][rows, 0]
            states[rows, tick], sensors[rows, tick] = (
                stepper.current[rows, 1:],
                stepper.sensors[EVERY][rows, -1],
            )

        stepper.run_blocks(self.pool, observe, act, record)
        return states, sensors, ctrl

    def close(self) -> None:
        """End the pool's worker threads."""
        self.pool.close()


def search_gait(
    problem: GaitProblem,
    settings: GaitSearchSettings,
    on_iteration: Callable[[Iteration], None] | None = None,
) -> GaitSearchResult:
    """Run the search; returns the best-scoring mean and each iteration's figures. Ctrl-C after the
    first iteration ends it early with the best so far (`interrupted`); before, it is raised as it
    is."""
    layout = problem.layout
    initial = stepping_in_place(layout) if problem.initial is None else problem.initial
    free = np.ones(len(initial), dtype=bool) if problem.free is None else problem.free
    cem = CEM(
        CEMConfig(
            num_rollouts=settings.population,
            num_nodes=1,
            num_elites=settings.elites,
            sigma_min=settings.sigma_min,
            sigma_max=settings.sigma_max,
        ),
        int(free.sum()),
    )
    rng = np.random.default_rng(settings.seed)
    cem.rng = np.random.default_rng(settings.seed + 1)
    mean, history, start = initial[free][None], [], time.perf_counter()
    best: GaitSearchResult | None = None
    best_score = -np.inf
    episodes = GaitEpisodes(problem, settings.workers)
    try:
        population, count = settings.population, settings.commands
        period = 1.0 / GAITS["trot"].frequency
        for index in range(settings.iterations):
            commands = np.array([problem.draw(rng) for _ in range(count)])
            # (population, free), row 0 the mean
            sampled = cem.sample_control_knots(mean)[:, 0]
            candidates = np.tile(initial, (population, 1))  # (population, P)
            candidates[:, free] = sampled
            rows = np.repeat(candidates, count, axis=0)
            row_commands = np.tile(commands, (population, 1))
            starts = rng.uniform(0.0, period, len(rows))
            states, sensors, ctrl = episodes.run(
                rows, row_commands, starts, settings.episode_seconds
            )
            rewards = np.zeros((population, count))
            for j, command in enumerate(commands):
                block = slice(j, None, count)  # rows of command j, one per candidate
                rewards[:, j] = problem.reward(states[block], sensors[block], ctrl[block], command)
            fell = states[..., 2] < problem.fallen_height
            fell = fell.any(axis=1).reshape(population, count)
            scores = rewards.mean(axis=1)
            mean = cem.update_nominal_knots(sampled[:, None], scores)
            seconds = time.perf_counter() - start
            record = Iteration(
                index, float(scores[0]), float(scores.max()), float(fell[0].mean()), seconds
            )
            history.append(record)
            # NaN never wins
            score = record.mean_reward if np.isfinite(record.mean_reward) else -np.inf
            if best is None or score > best_score:
                best, best_score = GaitSearchResult(candidates[0].copy(), index, history), score
            if on_iteration is not None:
                on_iteration(record)
    except KeyboardInterrupt:
        if best is None:
            raise
        best.interrupted = True
    finally:
        episodes.close()
    assert best is not None  # iterations >= 1 (validated)
    return best
