"""The warp backend's control update against the CPU pool's raw rollouts of the same N x T, for
large N.

For each task and N: the median control update on the warp backend (sample, roll out on the device,
reward, update), the median raw rollout of the same N x T steps on the CPU `RolloutPool` (one thread
per core), their ratio (the pool's rollout times the update's optimizer iterations over the warp
update; above 1 the whole warp update is faster than the CPU pool's physics alone), and the share of
the warp update spent stepping on the device, copying inputs to the device and states back, and in
the task's reward (what is left is the host's sampling, spline and optimizer update).

Warp runs on its default device: the GPU when there is one, otherwise warp's CPU device, which
launches every kernel of every step one after the other and is far slower than the pool; the header
says which.

PYTHONPATH=src python benchmarks/gpu_rollouts.py [--tasks cartpole leap_cube humanoid_standup]
    [--num-rollouts 64 256 1024 4096] [--horizon 0.5] [--samples 10] [--warmup 3]
"""

import math
import os
import platform
import time
from dataclasses import dataclass

import numpy as np
import tyro
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from judo.cli_shared import check_names
from judo.core.controller import Controller
from judo.core.errors import JudoError
from judo.core.rollouts.factory import check_rollout_backend
from judo.core.rollouts.rollout import RolloutPool
from judo.evaluation.timing import benchmark_controller, rollout_start
from judo.loop.system import MujocoSystem


@dataclass
class Args:
    """What to time, and how often."""

    tasks: tuple[str, ...] = ("cartpole", "leap_cube", "humanoid_standup")
    """Tasks, by registered name."""
    num_rollouts: tuple[int, ...] = (64, 256, 1024, 4096)
    """The N values to time."""
    optimizer: str = "mppi"
    """Optimizer, by registered name."""
    horizon: float = 0.5
    """Planning horizon in seconds (T = horizon / timestep; 0.5 s is T = 50 for every built-in
    task)."""
    samples: int = 10
    """Timed control updates (and CPU pool rollouts) per task and N."""
    warmup: int = 3
    """Untimed updates first (the first one compiles kernels, captures the graph and sizes the
    buffers)."""
    num_workers: int | None = None
    """CPU pool threads (default: one per core)."""


@dataclass
class Row:
    """Medians over the timed samples of one task and N, in milliseconds (shares in [0, 1])."""

    task: str
    num_rollouts: int
    num_steps: int
    iterations: int
    update_ms: float
    cpu_rollout_ms: float
    copy_share: float
    reward_share: float
    physics_share: float


def device_header() -> str:
    """Which device warp measured, with the versions; a CPU-device run says that it is not a GPU
    figure."""
    import mujoco_warp
    import warp as wp

    device = wp.get_device()
    cores = os.cpu_count()
    versions = f"warp {wp.config.version}, MuJoCo Warp {mujoco_warp.__version__}"
    if device.is_cuda:
        return (
            f"warp device: {device.alias} ({device.name}), {versions}; CPU pool: {cores} "
            f"cores ({platform.processor()})"
        )
    return (
        "warp device: cpu -- no CUDA device found, so these are warp's CPU-device figures, "
        "not GPU ones; "
        f"{versions}; CPU pool: {cores} cores"
    )


def time_task(task: str, num_rollouts: int, args: Args, advance) -> Row:
    """Time the warp controller's updates and the CPU pool's raw rollouts for one task and N."""
    controller = benchmark_controller(
        task, args.optimizer, num_rollouts=num_rollouts, horizon=args.horizon, backend="warp"
    )
    try:
        return time_controller(controller, task, args, advance)
    finally:
        controller.close()


def time_controller(controller: Controller, task: str, args: Args, advance) -> Row:
    start = MujocoSystem.from_task(controller.task, 0).read_state()
    state, metadata, now = start.state, start.metadata, start.time
    period = 1.0 / controller.config.control_freq
    # first start and last end of the reward calls of one update
    reward_span = [math.inf, -math.inf]
    reward = controller.task.reward

    def timed_reward(*reward_args, **reward_kwargs):
        # blocks of rows may run on several threads: time their wall span
        started = time.perf_counter()
        try:
            return reward(*reward_args, **reward_kwargs)
        finally:
            reward_span[0], reward_span[1] = (
                min(reward_span[0], started),
                max(reward_span[1], time.perf_counter()),
            )

    controller.task.reward = timed_reward  # type: ignore[method-assign]
    for _ in range(args.warmup + 1):
        plan = controller.update_action(state, now, metadata)
        now += period
    backend = controller.backend
    update_ms, copy_ms, reward_ms, physics_ms = [], [], [], []
    for _ in range(args.samples):
        backend.phase_seconds = dict.fromkeys(backend.phase_seconds, 0.0)  # type: ignore[attr-defined]
        reward_span[:] = [math.inf, -math.inf]
        started = time.perf_counter()
        controller.update_action(state, now, metadata)
        update_ms.append(1e3 * (time.perf_counter() - started))
        copy_ms.append(1e3 * (backend.phase_seconds["copy_in"] + backend.phase_seconds["copy_out"]))  # type: ignore[attr-defined]
        physics_ms.append(1e3 * backend.phase_seconds["physics"])  # type: ignore[attr-defined]
        # spans any physics between iterations too
        reward_ms.append(1e3 * max(0.0, reward_span[1] - reward_span[0]))
        now += period
        advance()

    # (num_rollouts, T, nu), as the updates roll out
    controls = np.ascontiguousarray(controller.batch_controls)
    initial, mocap = rollout_start(controller.task.model, state, plan.start_time, metadata)
    pool = RolloutPool(controller.task.model, args.num_workers)
    try:
        pool.rollout(initial, controls, mocap)  # warm-up: allocates the pool's buffers
        cpu_ms = []
        for _ in range(args.samples):
            started = time.perf_counter()
            pool.rollout(initial, controls, mocap)
            cpu_ms.append(1e3 * (time.perf_counter() - started))
            advance()
    finally:
        pool.close()
    median = float(np.median(update_ms))
    return Row(
        task=task,
        num_rollouts=controller.optimizer.num_rollouts,
        num_steps=controller.num_steps,
        iterations=controller.config.max_opt_iters,
        update_ms=median,
        cpu_rollout_ms=float(np.median(cpu_ms)),
        copy_share=float(np.median(copy_ms)) / median,
        reward_share=float(np.median(reward_ms)) / median,
        physics_share=float(np.median(physics_ms)) / median,
    )


def results_table(rows: list[Row], args: Args) -> Table:
    table = Table(
        title=f"{args.optimizer} control update on warp vs "
        "the CPU pool's raw rollouts (ms, medians)"
    )
    for column in (
        "task",
        "N x T",
        "iters",
        "warp update",
        "CPU pool rollout",
        "CPU / warp",
        "physics",
        "copies",
        "reward",
    ):
        table.add_column(column, justify="left" if column == "task" else "right")
    for row in rows:
        table.add_row(
            row.task,
            f"{row.num_rollouts} x {row.num_steps}",
            str(row.iterations),
            f"{row.update_ms:.1f}",
            f"{row.cpu_rollout_ms:.1f}",
            f"{row.iterations * row.cpu_rollout_ms / row.update_ms:.2f}x",
            f"{100 * row.physics_share:.1f}%",
            f"{100 * row.copy_share:.1f}%",
            f"{100 * row.reward_share:.1f}%",
        )
    return table


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    console = Console(width=140)
    try:
        check_names(args.tasks, [args.optimizer])
        check_rollout_backend("warp")  # MissingExtraError names judo-mpc[warp]
        header = device_header()
    except JudoError as err:
        console.print(f"error: {err}", style="red")
        raise SystemExit(2) from err
    console.print(header)
    console.print(
        f"horizon {args.horizon:g} s, {args.samples} samples after {args.warmup} warm-up updates"
    )
    rows = []
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=Console(stderr=True), transient=True) as progress:
        bar = progress.add_task(
            "gpu rollouts", total=2 * args.samples * len(args.tasks) * len(args.num_rollouts)
        )
        for task in args.tasks:
            for num_rollouts in args.num_rollouts:
                progress.update(bar, description=f"{task}, N = {num_rollouts}")
                rows.append(time_task(task, num_rollouts, args, lambda: progress.advance(bar)))
    console.print(results_table(rows, args))
    console.print(
        "CPU / warp: iters x CPU pool rollout / warp update; above 1 the whole warp update "
        "beats the CPU pool's "
        "physics alone. "
        "physics: the T steps on the device (waited for); copies: inputs to the device and "
        "states back; reward: the task's reward on the host (wall time, its row "
        f"blocks on up to {os.cpu_count()} threads)."
    )


if __name__ == "__main__":
    main()
