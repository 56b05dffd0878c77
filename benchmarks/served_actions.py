"""Served actions against the actuators' ctrlrange, and what clamping them costs per served action.

For each task, one closed-loop episode (seed 0): how many plant steps were served an action beyond
ctrlrange (always 0 now), and at how many of them the plan's spline, unclamped, would have served
one (what the clamp prevents: a cubic through knots at the limits overshoots them). Then the time of
one `Spline(t)` call with and without bounds, interleaved in one run.

PYTHONPATH=src python benchmarks/served_actions.py [--tasks cartpole pendulum acrobot
particle] [--duration 10]
"""

import timeit
from dataclasses import dataclass, field

import numpy as np
import tyro
from rich.console import Console
from rich.table import Table

import judo
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem


@dataclass
class Args:
    """Which tasks to run and for how long."""

    tasks: list[str] = field(
        default_factory=lambda: ["cartpole", "pendulum", "acrobot", "particle"]
    )
    """Tasks, by registered name (the cubic-spline ones are where a spline overshoots its knots)."""
    optimizer: str = "mppi"
    """Optimizer, by registered name."""
    duration: float = 10.0
    """Seconds of sim time per episode."""
    timing_samples: int = 60
    """Interleaved timing samples per spline order and bounds setting (the minimum is shown)."""


def unclamped(plan: judo.Spline) -> judo.Spline:
    """The same plan without bounds: what was served before actions were clamped."""
    return judo.Spline(plan.start_time, plan.basis, plan.knots)


def episode_row(task: str, optimizer: str, duration: float) -> list[str]:
    controller = judo.make_controller(task, optimizer, seed=0)
    low, high = controller.task.actuator_ctrlrange.T
    overshoots = 0
    served_plans: list[judo.Spline] = []
    update = controller.update_action

    def recording_update(*args, **kwargs):
        plan = update(*args, **kwargs)
        served_plans.append(plan)
        return plan

    controller.update_action = recording_update  # type: ignore[method-assign]
    try:
        result = run_episode(controller, MujocoSystem.from_task(controller.task, 0), duration)
    finally:
        controller.close()
    after_step, controls = result.log.times, result.log.controls
    # when each action was applied
    times = np.r_[2 * after_step[0] - after_step[1], after_step[:-1]]
    starts = np.array([plan.start_time for plan in served_plans])
    for t in times:
        index = np.searchsorted(starts, t + 1e-9, side="right") - 1
        if index >= 0:
            raw = unclamped(served_plans[index])(float(t))
            overshoots += bool(((raw < low - 1e-12) | (raw > high + 1e-12)).any())
    beyond = int(((controls < low - 1e-12) | (controls > high + 1e-12)).any(axis=1).sum())
    return [task, controller.config.spline_order, str(len(controls)), str(beyond), str(overshoots)]


def spline_call_us(order: str, bounded: bool) -> float:
    knots = np.array([[1.0], [-1.0], [1.0], [-1.0], [1.0], [-1.0]])
    bounds = (np.array([-1.0]), np.array([1.0])) if bounded else (None, None)
    spline = judo.Spline(0.0, judo.SplineBasis(np.linspace(0.0, 1.0, 6), order), knots, *bounds)  # type: ignore[arg-type]
    return min(timeit.repeat(lambda: spline(0.37), number=2000, repeat=3)) / 2000 * 1e6


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    console = Console()
    table = Table(title=f"served actions vs ctrlrange, {args.optimizer}, seed 0, {args.duration} s")
    for column in (
        "task",
        "spline",
        "plant steps",
        "served beyond range",
        "unclamped plan beyond range",
    ):
        table.add_column(column, justify="right")
    for task in args.tasks:
        table.add_row(*episode_row(task, args.optimizer, args.duration))
    console.print(table)
    timing = Table(
        title="one Spline(t) call, 6 knots, nu=1 (min of "
        f"{args.timing_samples} interleaved samples)"
    )
    for column in ("order", "no bounds (us)", "with bounds (us)", "ratio"):
        timing.add_column(column, justify="right")
    for order in ("linear", "cubic"):
        samples = {False: [], True: []}
        for _ in range(args.timing_samples):
            for bounded in (False, True):
                samples[bounded].append(spline_call_us(order, bounded))
        free, clamped = min(samples[False]), min(samples[True])
        timing.add_row(order, f"{free:.2f}", f"{clamped:.2f}", f"{clamped / free:.2f}")
    console.print(timing)


if __name__ == "__main__":
    main()
