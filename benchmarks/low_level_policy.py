"""A low-level policy inside every rollout: the control update against its floor, and what batching
buys.

For each N, timed interleaved from the task's start state (seed 0):
  - update: one control update of a task with a low-level policy (the optimizer plans commands;
    every k steps one batched `act` per worker's block of rollouts turns them into ctrl;
    judo.core.rollouts.low_level);
  - floor: the raw `mujoco.rollout` of the same N x T steps on the same pool (the very ctrl the
    policy gave in those rollouts, recorded once, so that the physics and its contacts are the
    same), plus ceil(T / k) batched
    `act` calls of the same (N, O) size (times max_opt_iters); the target is update / floor <= 1.3;
  - the hierarchical rollout alone, batched (one `act` of N rows per tick) and the 0.1.0
    way (one `act` of one row per rollout per tick: N calls per tick), and the speed-up batching
    gives.
Medians, and the ratio of the minima (the steadier figure on a loaded machine).

    PYTHONPATH=src python benchmarks/low_level_policy.py [--task cartpole_pd] [--num-rollouts 64 256]
"""  # noqa: E501

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
import tyro
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

import judo
from judo.core.configuration.registry import lookup_optimizer, make_config
from judo.core.policy import Policy
from judo.core.rollouts.low_level import LowLevel
from judo.core.rollouts.low_level_rollout import LowLevelRollout
from judo.core.rollouts.rollout import RolloutPool
from judo.evaluation.timing import rollout_start
from judo.loop.system import MujocoSystem


@dataclass
class Args:
    """What to time and how often."""

    task: str = "cartpole_pd"
    """A task with a low-level policy (`Task.low_level`), by registered name."""
    optimizer: str = "ps"
    """Optimizer, by registered name."""
    num_rollouts: list[int] = field(default_factory=lambda: [64, 256])
    """Rollouts per update (N), one row each."""
    samples: int = 20
    """Interleaved timed samples of each measurement per N, after `warmup`."""
    warmup: int = 3
    """Untimed rounds first."""
    num_workers: int | None = None
    """Rollout threads (default: one per core)."""
    cpu_time: bool = False
    """Time the calling thread's CPU time instead of wall time (needs --num-workers 1, so that all
    the work runs on the timed thread; far steadier on a loaded machine)."""


class RecordingPool(RolloutPool):
    """A rollout pool that keeps the ctrl of every step a low-level rollout takes on it: the floor's
    ctrl."""

    def record(self, num_rollouts: int, num_steps: int) -> None:
        """Keep the next low-level rollout's (num_rollouts, num_steps, nu) ctrl in `ctrl`."""
        self.ctrl = np.zeros((num_rollouts, num_steps, self.model.nu))
        self.steps_done = [0] * len(self.blocks(num_rollouts))

    def rollout_block(self, block, initial_states, inputs, control_spec, states, sensors) -> None:
        rows, start = self.blocks(len(initial_states))[block], self.steps_done[block]
        self.ctrl[rows, start : start + inputs.shape[1]] = inputs[rows, :, : self.model.nu]
        self.steps_done[block] += inputs.shape[1]
        super().rollout_block(block, initial_states, inputs, control_spec, states, sensors)


def ctrl_of(low: LowLevel, pool: RolloutPool, initial, commands, mocap) -> np.ndarray:
    """(N, T, nu) the ctrl the low-level policy gives in the rollouts of (N, T, C) `commands` from
    `initial`."""
    recording = RecordingPool(pool.model, pool.num_workers)
    recording.record(*commands.shape[:2])
    with LowLevelRollout(recording, low) as backend:
        backend.rollout(initial, commands, mocap)
    return recording.ctrl


class OneRowAtATime(Policy):
    """`policy` called once per row: the 0.1.0 way (one inference of batch 1 per rollout per
    tick)."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy
        self.observation_size, self.action_size, self.horizon = (
            policy.observation_size,
            policy.action_size,
            policy.horizon,
        )
        self.metadata = {
            **getattr(policy, "metadata", {}),
            "name": f"{policy.name} one row at a time",
        }

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [self.policy.act(observations[i : i + 1]) for i in range(len(observations))]
        )


def time_ms(call, clock) -> float:
    started = clock()
    call()
    return 1e3 * (clock() - started)


def row(args: Args, num_rollouts: int, progress: Progress, bar) -> list[str]:
    optimizer_config = make_config(lookup_optimizer(args.optimizer)[1], args.task)
    optimizer_config.num_rollouts = num_rollouts  # type: ignore[attr-defined]
    with judo.make_controller(
        args.task,
        args.optimizer,
        optimizer_config=optimizer_config,
        num_workers=args.num_workers,
        seed=0,
    ) as controller:
        backend = controller.backend
        assert isinstance(backend, LowLevelRollout), (
            f"task {args.task!r} declares no low-level policy"
        )
        low, pool, model = backend.low_level, backend.inner, controller.task.model
        reading = MujocoSystem.from_task(controller.task, 0).read_state()
        initial, mocap = rollout_start(model, reading.state, reading.time, reading.metadata)
        num_steps, ticks = controller.num_steps, math.ceil(controller.num_steps / low.every)
        observations = np.random.default_rng(0).normal(
            size=(num_rollouts, low.policy.observation_size)
        )
        observations = observations.astype(float)
        one_row = LowLevelRollout(pool, dataclasses.replace(low, policy=OneRowAtATime(low.policy)))
        times: dict[str, list[float]] = {"update": [], "floor": [], "batched": [], "one_row": []}
        plan_time = reading.time

        def update() -> None:
            nonlocal plan_time
            controller.update_action(reading.state, plan_time, reading.metadata)
            plan_time += 1.0 / controller.config.control_freq

        def floor() -> None:
            for _ in range(controller.config.max_opt_iters):
                pool.rollout(initial, ctrl, mocap)
                for _ in range(ticks):
                    low.policy.act(observations)

        # one plan first, so that the floor's ctrl is what the policy gives on the optimizer's
        # commands
        update()
        ctrl = ctrl_of(low, pool, initial, controller.batch_controls, mocap)
        commands = controller.batch_controls  # (N, T, C), a view: what the last update rolled out
        clock = time.thread_time if args.cpu_time else time.perf_counter
        for sample in range(args.warmup + args.samples):
            measured = {
                "update": time_ms(update, clock),
                "floor": time_ms(floor, clock),
                "batched": time_ms(lambda: backend.rollout(initial, commands, mocap), clock),
                "one_row": time_ms(lambda: one_row.rollout(initial, commands, mocap), clock),
            }
            if sample >= args.warmup:
                for name, value in measured.items():
                    times[name].append(value)
                progress.advance(bar)
        median = {name: float(np.median(values)) for name, values in times.items()}
        least = {name: min(values) for name, values in times.items()}
    return [
        f"{num_rollouts} x {num_steps}",
        f"{low.every} ({ticks})",
        f"{median['update']:.2f}",
        f"{median['floor']:.2f}",
        f"{median['update'] / median['floor']:.2f} ({least['update'] / least['floor']:.2f})",
        f"{median['batched']:.2f}",
        f"{median['one_row']:.2f}",
        f"{median['one_row'] / median['batched']:.1f}x",
    ]


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    if args.cpu_time and args.num_workers != 1:
        raise SystemExit(
            "--cpu-time needs --num-workers 1, so that every rollout runs on the timed thread"
        )
    what = "thread CPU time" if args.cpu_time else "wall time"
    table = Table(
        title=f"{args.task} x {args.optimizer}: low-level policy inside every rollout, median of "
        f"{args.samples} "
        f"({what})"
    )
    columns = ("N x T", "k (ticks)", "update ms", "floor ms", "update / floor (min/min)")
    for column in (
        *columns,
        "rollout ms, batched act",
        "rollout ms, one act per rollout",
        "batching buys",
    ):
        table.add_column(column, justify="right")
    progress_columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*progress_columns, console=Console(stderr=True), transient=True) as progress:
        bar = progress.add_task("low-level policy", total=args.samples * len(args.num_rollouts))
        rows = [row(args, num_rollouts, progress, bar) for num_rollouts in args.num_rollouts]
    for cells in rows:
        table.add_row(*cells)
    Console(width=160).print(table)


if __name__ == "__main__":
    main()
