"""Where a control update's fixed cost goes: the update without its physics, split into the task's
reward and the rest.

For each task (its default settings, one rollout worker, the calling thread's CPU time) it plans a
few updates, keeps the last batch's states and sensors, and from then on replays them in place of
the rollouts: what is left of an update is its fixed cost (sampling, clamping, the spline, the
reward, the optimizer's update, the plan and its traces). It prints that per optimizer iteration
next to the task's reward alone on the same batch, and the rest. `--profile N` adds cProfile's N
costliest functions of those updates (call counts do not depend on the machine's load; its times,
wall times, do). The reward column is timed alone, on warm caches; `--after-rollout` puts a real
rollout
(untimed) before each timed update, so that the update finds the caches as a rollout leaves them.

    PYTHONPATH=src python benchmarks/fixed_cost.py [--tasks cartpole acrobot] [--optimizer mppi] [--profile 25]
    PYTHONPATH=src python benchmarks/fixed_cost.py --tasks cartpole --num-rollouts 32 --horizon 0.25
    PYTHONPATH=src python benchmarks/fixed_cost.py --tasks pendulum --after-rollout   # with the caches a rollout leaves
"""  # noqa: E501

import cProfile
import pstats
import time
from dataclasses import dataclass

import tyro
from rich.console import Console
from rich.table import Table

from judo import get_registered_tasks
from judo.core.configuration.config import snapshot
from judo.core.reading import SystemState
from judo.evaluation.timing import benchmark_controller, rollout_start
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem


@dataclass
class Args:
    """Tasks, sizes and repetitions."""

    tasks: tuple[str, ...] = ()
    """Tasks to look at (default: every registered one)."""
    optimizer: str = "mppi"
    """Optimizer, by registered name."""
    updates: int = 200
    """Timed updates per task (and as many reward calls)."""
    num_rollouts: int | None = None
    """Rollouts per update (default: the task's)."""
    horizon: float | None = None
    """Planning horizon in seconds (default: the task's)."""
    after_rollout: bool = False
    """Roll the batch out for real (untimed) before each timed update, as an update's own rollout
    does: the caches the update needs are then as cold as in a real update."""
    profile: int = 0
    """Print cProfile's this many costliest functions (by own time) of each task's updates; 0:
    none."""


def measure(task: str, args: Args) -> tuple[tuple[str, ...], cProfile.Profile | None]:
    """The table's row for `task` (and the profile of its updates, where asked for)."""
    sizes = {"num_rollouts": args.num_rollouts, "horizon": args.horizon}
    with benchmark_controller(task, args.optimizer, num_workers=1, **sizes) as controller:
        loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, 0))
        start = loop.restart()
        period, plan_time = 1.0 / controller.config.control_freq, start.time

        def update() -> None:
            nonlocal plan_time
            loop.plan(SystemState(start.state, plan_time, start.metadata))
            plan_time += period

        for _ in range(5):
            update()
        initial, mocap = rollout_start(
            controller.task.model, start.state, plan_time, start.metadata
        )
        controls = controller.batch_controls
        real_rollout = controller.backend.rollout
        states, sensors = (array.copy() for array in real_rollout(initial, controls, mocap))
        # the physics replayed: what is left is fixed
        controller.backend.rollout = lambda *_: (states, sensors)
        batch = controls.copy()
        for _ in range(5):
            update()
        profiler = cProfile.Profile() if args.profile else None
        elapsed = 0.0
        for _ in range(args.updates):
            if args.after_rollout:
                real_rollout(initial, batch, mocap)
            started = time.thread_time()
            if profiler is not None:
                profiler.enable()
            update()
            if profiler is not None:
                profiler.disable()
            elapsed += time.thread_time() - started
        iters = controller.config.max_opt_iters
        per_iteration = 1e6 * elapsed / args.updates / iters
        config, num_state = (
            snapshot(controller.task.config),
            controller.task.model.nq + controller.task.model.nv,
        )
        # [qpos, qvel], as the controller hands them to the reward
        planned = states[..., 1 : 1 + num_state]
        started = time.thread_time()
        for _ in range(args.updates):
            controller.task.reward(planned, sensors, controls, config, start.metadata)
        reward = 1e6 * (time.thread_time() - started) / args.updates
        shape = f"{controller.optimizer.num_rollouts} x {controller.num_steps}"
    row = (
        task,
        shape,
        str(iters),
        f"{per_iteration:.0f}",
        f"{reward:.0f}",
        f"{per_iteration - reward:.0f}",
    )
    return row, profiler


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    known = get_registered_tasks()
    tasks = args.tasks or tuple(known)
    for task in tasks:
        if task not in known:
            raise SystemExit(f"unknown task {task!r}; expected one of {', '.join(known)}")
    after = ", each after a real rollout" if args.after_rollout else ""
    table = Table(
        title=f"an update without its physics, per optimizer iteration ({args.optimizer}, thread "
        f"CPU time, us{after})"
    )
    for column in ("task", "N x T", "iters", "update without physics", "reward", "the rest"):
        table.add_column(column, justify="left" if column == "task" else "right")
    for task in tasks:
        row, profiler = measure(task, args)
        table.add_row(*row)
        if profiler is not None:
            print(
                f"--- {task}: the {args.profile} costliest functions of {args.updates} updates "
                "without physics"
            )
            pstats.Stats(profiler).sort_stats("tottime").print_stats(args.profile)
    Console(width=120).print(table)


if __name__ == "__main__":
    main()
