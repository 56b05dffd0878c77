"""Control-update time of the newer optimizers against MPPI's at the same N, knots and
horizon (target: within 10%).

Every optimizer of a task runs the same sizes, and their timings are interleaved: each round times a
few updates of every optimizer in turn, so a load that comes and goes on a shared machine lands on
all of them alike. The figures are the median update, the rollout floor (the raw rollouts of the
same batch), the update's fixed cost beyond the floor, the ratio of its median update to MPPI's, and
the optimizer's own time per iteration
(pre_optimization, sample_control_knots and update_nominal_knots on the update's last batch, outside
the controller: the best of 5 means of 100 calls, far steadier than the update's median). Run from
the repository root:

    PYTHONPATH=src python benchmarks/optimizer_update_time.py [--tasks cartpole walker leap_cube] [--rounds 10]

The defaults time one worker thread's CPU time (--no-cpu-time for wall time with --num-workers N).
"""  # noqa: E501

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import tyro
from rich.console import Console
from rich.table import Table

from judo import Controller, get_registered_optimizers, get_registered_tasks
from judo.evaluation.timing import benchmark_controller, time_control_update


@dataclass
class Args:
    """Sizes, optimizers and repetitions of the comparison."""

    tasks: tuple[str, ...] = ("cartpole", "walker", "leap_cube")
    """Tasks to time."""
    optimizers: tuple[str, ...] = ("mppi", "mppi_cma", "er_cma", "mtp", "cbo")
    """Optimizers to time; the first is the reference of the ratio column."""
    num_rollouts: int = 32
    """Rollouts per update (N)."""
    num_nodes: int = 4
    """Spline knots per plan."""
    horizon: float = 0.5
    """Planning horizon in seconds (T = horizon / timestep steps)."""
    rounds: int = 10
    """Rounds of interleaved timing; each times --per-round updates of every optimizer."""
    per_round: int = 10
    """Timed updates of one optimizer per round (after 2 untimed ones)."""
    num_workers: int = 1
    """Rollout worker threads."""
    cpu_time: bool = True
    """Time the calling thread's CPU time (needs --num-workers 1); steadier than wall time on a busy
    machine."""


def optimizer_us(
    controller: Controller, clock: Callable[[], float], calls: int = 100, repeats: int = 5
) -> float:
    """Microseconds per iteration of the controller's optimizer alone, on the batch and rewards of
    its last update."""
    opt, rewards = controller.optimizer, controller.rewards.copy()
    nominal = np.asarray(controller.nominal_knots, dtype=float)
    times = np.linspace(0.0, controller.config.horizon, opt.num_nodes)
    period = 1.0 / controller.config.control_freq
    best = np.inf
    for _ in range(repeats):
        started = clock()
        for _ in range(calls):
            opt.pre_optimization(times, times + period)
            knots = opt.sample_control_knots(nominal)
            opt.update_nominal_knots(knots, rewards)
        best = min(best, (clock() - started) / calls)
    return 1e6 * best


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    if args.cpu_time and args.num_workers != 1:
        raise SystemExit(
            "--cpu-time needs --num-workers 1, so that every rollout runs on the timed thread"
        )
    for kind, names, known in (
        ("task", args.tasks, get_registered_tasks()),
        ("optimizer", args.optimizers, get_registered_optimizers()),
    ):
        unknown = [name for name in names if name not in known]
        if unknown:
            raise SystemExit(f"unknown {kind} {unknown[0]!r}; expected one of {', '.join(known)}")
    clock = time.thread_time if args.cpu_time else time.perf_counter
    reference = args.optimizers[0]
    table = Table(
        title=f"control update, N={args.num_rollouts}, {args.num_nodes} knots, {args.horizon:g} s, "
        + ("thread CPU time" if args.cpu_time else "wall time")
        + f", {args.rounds} x {args.per_round} updates each"
    )
    columns = (
        "task",
        "optimizer",
        "N x T x nu",
        "update median (ms)",
        "rollout floor (ms)",
        "fixed cost (us)",
    )
    for column in (
        *columns,
        f"vs {reference}",
        "optimizer (us)",
        f"optimizer - {reference}'s (us)",
    ):
        table.add_column(column, justify="left" if column in ("task", "optimizer") else "right")
    sizes = {
        "num_rollouts": args.num_rollouts,
        "num_nodes": args.num_nodes,
        "horizon": args.horizon,
    }
    for task in args.tasks:
        controllers = {
            name: benchmark_controller(task, name, num_workers=args.num_workers, **sizes)
            for name in args.optimizers
        }
        update_ms = {name: [] for name in args.optimizers}
        floor_ms = {name: [] for name in args.optimizers}
        for _ in range(args.rounds):
            for name, controller in controllers.items():
                updates, floors = time_control_update(
                    controller, args.per_round, warmup=2, clock=clock
                )
                update_ms[name].append(updates)
                # one batch per iteration
                floor_ms[name].append(floors * controller.config.max_opt_iters)
        medians = {
            name: float(np.median(np.concatenate(update_ms[name]))) for name in args.optimizers
        }
        own = {name: optimizer_us(controller, clock) for name, controller in controllers.items()}
        for name, controller in controllers.items():
            floor = float(np.median(np.concatenate(floor_ms[name])))
            shape = controller.batch_controls.shape
            table.add_row(
                task,
                name,
                " x ".join(str(n) for n in shape),
                f"{medians[name]:.3f}",
                f"{floor:.3f}",
                f"{1e3 * (medians[name] - floor):.0f}",
                f"{medians[name] / medians[reference]:.3f}x",
                f"{own[name]:.0f}",
                f"{own[name] - own[reference]:+.0f}",
            )
            controller.close()
    Console(width=160).print(table)


if __name__ == "__main__":
    main()
