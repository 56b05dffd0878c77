"""What feedback gains on the served plan buy (`--controller.feedback`), and what they cost per
update.

For each task, planning rate (20, 10, 5 Hz, and 10 Hz with 25 ms of latency) and plant, runs
closed-loop episodes (the evaluate machinery: `run_episode` on the task's defaults, sim time, seeds
from --first-seed) with each optimizer: on the task's defaults, with latency compensation (where the
task has it off), and with feedback (whose plans start from the predicted reading too), and prints
each task's two headline metrics (mean over seeds).

Two plants:
- "same": the plant is the planning model. Without latency the plant then follows the nominal
  rollout to rounding error, x - x_nom(t) ~ 0, and no feedback law can change much: the rows differ
  only where rounding grows through a chaotic episode (a check).
- "heavier": every body of the plant is --mass-scale times heavier (inertia too) than the planner
  thinks, so the plant drifts off the plan between replans; this is what the gains are for.

Then, on one machine in one run, the median control update with and without the gains (their ratio
is what the gains add; each optimizer's against the first's) and the serving time of one action: the
plain spline, and the spline with the gains.

    PYTHONPATH=src python benchmarks/feedback.py --tasks cartpole walker --first-seed 500
    PYTHONPATH=src python benchmarks/feedback.py --tasks cartpole --optimizers mppi ilqr --plants heavier
    PYTHONPATH=src python benchmarks/feedback.py --tasks cartpole walker quadruped --timing-only
    PYTHONPATH=src python benchmarks/feedback.py --tasks cartpole --iterations-per-second 0

Every cell plans with `controller.iterations_per_second` (each cycle at least that many optimizer
iterations per second of control: 4 a cycle at 5 Hz for the default 20), so a slow planning rate
searches as much per second as
20 Hz does with one iteration a cycle; `--iterations-per-second 0` plans with max_opt_iters a cycle,
whatever the rate (the default before it was 20).
"""  # noqa: E501

import argparse
import time
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from judo.core.feedback_plan import FeedbackPlan
from judo.evaluation.episode import run_episode
from judo.evaluation.seeded import EpisodeSpec, configs_in_force, spec_controller
from judo.loop.system import MujocoSystem

CONDITIONS = [(20.0, 0.0), (10.0, 0.0), (5.0, 0.0), (10.0, 25.0)]
"""(planning rate in Hz, latency in ms) of each column."""
DEFAULT_SEEDS = {"cartpole": (3, 10.0), "walker": (2, 8.0), "quadruped": (2, 15.0)}
"""Seeds and seconds per episode of each task (others: 2 seeds of 10 s)."""
VARIANTS = {
    "": {"controller.feedback": False},
    " + latency compensation": {
        "controller.feedback": False,
        "controller.latency_compensation": True,
    },
    " + feedback": {"controller.feedback": True},
}
"""Each optimizer's rows: the task's defaults, with latency compensation (left out where the task
has it on), and with feedback gains (which plan from the predicted reading as latency compensation
does)."""
HEADLINE = {
    "quadruped": ["goals_per_minute", "falls"],
    "humanoid_standup": ["standing_fraction", "final_head_height"],
}
"""The two metrics printed for a task; by default the first two of its `metrics`."""


@dataclass
class Cell:
    """Mean metrics over seeds and every update's wall time (ms) of one configuration."""

    metrics: dict[str, float]
    update_ms: list[float]


def run_cell(
    task: str,
    optimizer: str,
    rate: float,
    latency_ms: float,
    variant: str,
    mass_scale: float,
    seeds: Iterable[int],
    duration: float,
    iterations_per_second: float | None = None,
) -> Cell:
    values = {"controller.control_freq": rate, **VARIANTS[variant]}
    if iterations_per_second is not None:  # else the config's own (20 by default)
        values["controller.iterations_per_second"] = iterations_per_second
    spec = EpisodeSpec(task, optimizer, duration, latency_ms / 1e3, values, num_workers=2)
    configs = configs_in_force(spec)
    rows, update_ms = [], []
    for seed in seeds:
        with spec_controller(spec, configs, seed) as controller:
            controller.task.config = configs["task"]
            system = MujocoSystem.from_task(controller.task, seed)
            plant = system.task.sim_model  # the plant's own model, apart from the planner's
            plant.body_mass[:] *= mass_scale
            plant.body_inertia[:] *= mass_scale
            result = run_episode(controller, system, duration, spec.latency, seed)
        rows.append(result.metrics)
        update_ms += result.update_ms.tolist()
    return Cell({k: float(np.mean([r[k] for r in rows])) for k in rows[0]}, update_ms)


def default_compensation(task: str) -> bool:
    """Whether the task's own controller config plans with latency compensation."""
    return bool(configs_in_force(EpisodeSpec(task, "mppi", 1.0))["controller"].latency_compensation)


def timings(task: str, optimizer: str, updates: int = 10) -> tuple[float, float, float, float]:
    """From one start state: the median update without and with the gains in ms (alternating, so
    that a busy machine slows both alike), and the microseconds to serve one action of the plain
    spline and with the gains."""
    spec = EpisodeSpec(task, optimizer, 1.0, num_workers=2)
    configs = configs_in_force(spec)
    with spec_controller(spec, configs, 0) as controller:
        controller.task.reset()
        data = controller.task.data
        state = np.concatenate([data.qpos, data.qvel])
        metadata = controller.task.get_sim_metadata()
        update_ms: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(updates):
            for feedback in (False, True):
                controller.config.feedback = feedback
                start = time.perf_counter()
                plan = controller.update_action(state, 0.0, metadata)
                update_ms[feedback].append(1e3 * (time.perf_counter() - start))
        assert isinstance(plan, FeedbackPlan) and plan.gains is not None, plan
        serving = []
        for with_state in (None, state + 1e-3):
            start = time.perf_counter()
            for i in range(2000):
                plan(0.001 * (i % 50), with_state)
            serving.append((time.perf_counter() - start) / 2000 * 1e6)
    return (
        float(np.median(update_ms[False])),
        float(np.median(update_ms[True])),
        serving[0],
        serving[1],
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--tasks", nargs="+", default=["cartpole", "walker"])
    parser.add_argument(
        "--optimizers", nargs="+", default=["mppi"], help="each without and with feedback"
    )
    parser.add_argument("--first-seed", type=int, default=500)
    parser.add_argument(
        "--seeds", type=int, help="episodes per cell (default: per task, see DEFAULT_SEEDS)"
    )
    parser.add_argument(
        "--duration", type=float, help="seconds of sim time per episode (default: per task)"
    )
    parser.add_argument(
        "--mass-scale", type=float, default=1.25, help="the heavier plant's mass factor"
    )
    parser.add_argument(
        "--plants", nargs="+", default=["same", "heavier"], choices=["same", "heavier"]
    )
    parser.add_argument(
        "--timing-only", action="store_true", help="only the update and serving times, no episodes"
    )
    parser.add_argument(
        "--iterations-per-second",
        type=float,
        default=None,
        help="plan with this controller.iterations_per_second (default: the task's own, 20; 0: "
        "max_opt_iters a cycle)",
    )
    args = parser.parse_args()
    header = " | ".join(
        f"{rate:g} Hz" + (f" + {lat:g} ms" if lat else "") for rate, lat in CONDITIONS
    )
    for task in args.tasks:
        num_seeds, duration = DEFAULT_SEEDS.get(task, (2, 10.0))
        num_seeds, duration = args.seeds or num_seeds, args.duration or duration
        seeds = range(args.first_seed, args.first_seed + num_seeds)
        print(
            f"\n{task}, {num_seeds} seeds x {duration:g} s (seeds {seeds.start}-{seeds.stop - 1})",
            flush=True,
        )
        variants = [
            v for v in VARIANTS if v != " + latency compensation" or not default_compensation(task)
        ]
        times: dict[tuple[str, str], list[float]] = {
            (o, v): [] for o in args.optimizers for v in variants
        }
        names: list[str] = []
        for plant in [] if args.timing_only else args.plants:
            scale = args.mass_scale if plant == "heavier" else 1.0
            lines: dict[tuple[str, str], list[str]] = {key: [] for key in times}
            for optimizer, variant in times:
                for rate, latency in CONDITIONS:
                    cell = run_cell(
                        task,
                        optimizer,
                        rate,
                        latency,
                        variant,
                        scale,
                        seeds,
                        duration,
                        args.iterations_per_second,
                    )
                    headline = [k for k in HEADLINE.get(task, []) if k in cell.metrics]
                    names = names or headline or [k for k in cell.metrics if k != "mean_reward"][:2]
                    lines[optimizer, variant].append(
                        " / ".join(f"{cell.metrics[k]:.2f}" for k in names)
                    )
                    times[optimizer, variant] += cell.update_ms
            label = f"plant {plant}" + (f" (mass x {scale:g})" if plant == "heavier" else "")
            print(f"| {label}: {' / '.join(names)} | {header} |")
            print("|---|" + "---|" * len(CONDITIONS))
            for (optimizer, variant), cells in lines.items():
                print(f"| {optimizer}{variant} | {' | '.join(cells)} |", flush=True)
        base = np.median(times[args.optimizers[0], ""]) if not args.timing_only else np.nan
        for optimizer in args.optimizers:
            plain = np.median(times[optimizer, ""] or [np.nan])
            gains = np.median(times[optimizer, " + feedback"] or [np.nan])
            alone, with_gains, spline_us, feedback_us = timings(task, optimizer)
            in_episodes = (
                ""
                if args.timing_only
                else f" in the episodes: median {plain:.2f} ms without gains (x "
                f"{plain / base:.2f} of "
                f"{args.optimizers[0]}'s), {gains:.2f} ms with;"
            )
            print(
                f"{optimizer} update{in_episodes} from one state, alternating: {alone:.2f} ms, "
                f"{with_gains:.2f} ms with gains (x {with_gains / alone:.2f}); serving one action: "
                f"{spline_us:.1f} us plain, {feedback_us:.1f} us with gains",
                flush=True,
            )


if __name__ == "__main__":
    main()
