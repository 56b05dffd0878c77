"""A legged robot's floating base, estimated from the IMU, the joint encoders and the foot contacts:
how far each estimator's base is from the truth, and what planning from it costs.

    PYTHONPATH=src python benchmarks/base_estimation.py      # go2_stand, go2_walk, g1_stand: legged, ekf; 2 seeds x 8 s
    PYTHONPATH=src python benchmarks/base_estimation.py --tasks g1_stand --optimizer ps    # g1_stand's own optimizer
    PYTHONPATH=src python benchmarks/base_estimation.py --tasks go2_stand --estimators ukf --seeds 1  # 2n sigma points
    PYTHONPATH=src python benchmarks/base_estimation.py --tasks quadruped --sensing ideal

Each row is seeded episodes of `evaluate` (the one seeded runner, `run_seeded_episode`'s pieces),
planned from the true state ("full state") or from `--observe sensors` through an estimator, with a
robot's sensing (ROBOT below, or "ideal": noiseless, every plant step, at once). Per estimator, from
the plant's true state after each step, mean and max over the episode after its first SETTLE
seconds, then mean over seeds:
- height: |z estimate - z true| of the base (m);
- attitude: the angle of the rotation from the true base orientation to the estimate's (deg);
- velocity: |linear velocity estimate - true| of the base, in the world frame (m/s);
- drift: the base's planar distance from the truth at the episode's end (m; may drift: nothing
  measures it);
- update: the estimator's median wall time per update (ms; varies with the machine's load);
- the task's `--metrics` that it has (always from the plant's truth), and the first's ratio to the
  full state's.
"""  # noqa: E501

import argparse
import time
from typing import Any

import mujoco
import numpy as np

import judo  # noqa: F401  (registers the tasks, optimizers and estimators)
from judo.core.configuration.registry import lookup_estimator
from judo.core.estimator import ControlHistory, Estimator
from judo.evaluation.episode import run_episode
from judo.evaluation.seeded import (
    EpisodeSpec,
    configs_in_force,
    plant_of,
    spec_controller,
    with_spec_plant,
)
from judo.evaluation.sensing import Sensing, choose_estimator, observed_plant
from judo.loop.records import PlanRecord, StepRecord

ROBOT: dict[str, Any] = {
    "noise": {
        "jointpos": 0.005,
        "jointvel": 0.1,
        "framequat": float(np.deg2rad(0.5)),
        "gyro": 0.01,
        "accelerometer": 0.1,
        "touch": 5.0,
    },
    "rate": 500.0,
    "delay": 0.002,
}
"""A Unitree robot's rt/lowstate as rehearsed here: encoders 5 mrad and 0.1 rad/s, the IMU 0.5 deg,
0.01 rad/s and 0.1 m/s^2, foot forces 5 N, at 500 Hz (every plant step of a model stepped at 2 ms or
more), 2 ms late."""
KALMAN = {"noise_other": 20.0}
"""The EKF's and UKF's settings here (their TOMLs' for quadruped): the std of a sensor type without
a field of its own, the feet's touch sensors (N) and the joint speeds, which the default 0.01 trusts
as exact (the EKF's estimate of a Go2 held at its standing pose flew off a metre high with it)."""
SETTLE = 0.5
"""Seconds at an episode's start left out of the error figures (the estimator's first readings)."""


class Timed(Estimator):
    """`estimator`, with the wall time of each update kept in `walls` (s)."""

    def __init__(self, estimator: Estimator) -> None:
        self.task, self.estimator, self.config = estimator.task, estimator, estimator.config
        self.walls: list[float] = []

    def reset(self, reading):
        self.estimator.reset(reading)

    def update(self, reading, time_now: float, controls: ControlHistory):
        started = time.perf_counter()
        estimate = self.estimator.update(reading, time_now, controls)
        self.walls.append(time.perf_counter() - started)
        return estimate


class BaseErrors:
    """A recorder of the base estimate's errors against the plant's truth, one row per plant step
    after SETTLE.

    Attributes:
        rows: per step, (height m, attitude deg, velocity m/s, planar distance m).
    """

    def __init__(self, nq: int) -> None:
        self.nq = nq
        self.rows: list[tuple[float, float, float, float]] = []

    def on_plan(self, record: PlanRecord) -> None:
        pass

    def on_step(self, record: StepRecord) -> None:
        if record.estimate is None or record.state is None or record.time < SETTLE:
            return
        truth, estimate, nq = record.state, record.estimate, self.nq
        rotation = np.zeros(3)
        mujoco.mju_subQuat(rotation, estimate[3:7], truth[3:7])
        self.rows.append(
            (
                abs(estimate[2] - truth[2]),
                float(np.rad2deg(np.linalg.norm(rotation))),
                float(np.linalg.norm(estimate[nq : nq + 3] - truth[nq : nq + 3])),
                float(np.linalg.norm(estimate[:2] - truth[:2])),
            )
        )


def episode(
    task: str, optimizer: str, seed: int, duration: float, estimator: str | None, sensing: str
) -> dict:
    """One seeded episode of `task`: {"metrics": the task's metrics, "errors": (steps, 4) BaseErrors
    rows, "walls": (updates,) s}; `estimator` None plans from the full state."""
    settings = {} if sensing == "ideal" else ROBOT
    config = None
    if estimator in ("ekf", "ukf"):
        config = lookup_estimator(estimator)[1](**KALMAN)
    observed = (
        Sensing()
        if estimator is None
        else Sensing("sensors", **settings, estimator=estimator, estimator_config=config)
    )
    spec = EpisodeSpec(task, optimizer, duration, sensing=observed)
    configs = configs_in_force(spec)
    with spec_controller(spec, configs, seed) as controller:
        controller.task.config = configs["task"]
        system = observed_plant(with_spec_plant(controller.task, spec), seed, spec.sensing)
        _, chosen = choose_estimator(controller.task, task, system, spec.sensing)
        timed = None if chosen is None else Timed(chosen)
        errors = BaseErrors(plant_of(system).task.sim_model.nq)
        result = run_episode(controller, system, duration, 0.0, seed, None, [errors], timed)
    return {
        "metrics": result.metrics,
        "errors": np.array(errors.rows).reshape(-1, 4),
        "walls": np.array([] if timed is None else timed.walls),
    }


def table(args: argparse.Namespace) -> None:
    """Print one block per task: a row for the full state, then one per estimator."""
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(
        f"seeds {seeds.start}-{seeds.stop - 1} x {args.duration:g} s, {args.optimizer}; ekf "
        f"and ukf with {KALMAN}; "
        f"sensing {args.sensing}"
        f"{'' if args.sensing == 'ideal' else f' {ROBOT}'}; errors after the first "
        f"{SETTLE:g} s, mean (max) over "
        "steps, mean over seeds"
    )
    for task in args.tasks:
        full_runs = [
            episode(task, args.optimizer, seed, args.duration, None, args.sensing) for seed in seeds
        ]
        metric_names = [m for m in args.metrics if m in full_runs[0]["metrics"]] or list(
            full_runs[0]["metrics"]
        )[:2]
        full = np.mean([r["metrics"][metric_names[0]] for r in full_runs])
        print(
            f"\n{task}: {'row':11} {'height m':>15} {'attitude deg':>15} "
            f"{'velocity m/s':>15} {'drift m':>8} "
            f"{'update ms':>9} " + " ".join(f"{m:>22}" for m in metric_names) + f" {'/full':>6}"
        )
        for name in [None, *args.estimators]:
            runs = (
                full_runs
                if name is None
                else [
                    episode(task, args.optimizer, seed, args.duration, name, args.sensing)
                    for seed in seeds
                ]
            )
            print(
                f"{'':{len(task) + 1}} {name or 'full state':11} {row(runs, metric_names, full)}",
                flush=True,
            )


def row(runs: list[dict], metric_names: list[str], full: float) -> str:
    """One table row's cells: the base errors (blank for the full state), the update time and the
    metrics."""
    errors = [r["errors"] for r in runs if len(r["errors"])]
    if not errors:
        cells = [f"{'':>15} {'':>15} {'':>15} {'':>8} {'':>9}"]
    else:
        mean = np.mean([e.mean(axis=0) for e in errors], axis=0)
        worst = np.mean([e.max(axis=0) for e in errors], axis=0)
        drift = np.mean([e[-1, 3] for e in errors])
        wall = 1e3 * np.median(np.concatenate([r["walls"] for r in runs]))
        cells = [
            f"{mean[0]:>6.4f} ({worst[0]:6.4f}) {mean[1]:>6.2f} ({worst[1]:6.2f}) "
            f"{mean[2]:>6.3f} ({worst[2]:6.3f}) {drift:>8.3f} {wall:>9.2f}"
        ]
    values = {m: np.array([r["metrics"][m] for r in runs]) for m in metric_names}
    cells += [f"{v.mean():>10.3f} ± {v.std():<9.3f}" for v in values.values()]
    ratio = values[metric_names[0]].mean() / full if full else float("nan")
    return " ".join(cells) + f" {ratio:>6.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--tasks", nargs="+", default=["go2_stand", "go2_walk", "g1_stand"])
    parser.add_argument("--estimators", nargs="+", default=["legged", "ekf"])
    parser.add_argument("--optimizer", default="mppi")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument(
        "--metrics",
        nargs="+",
        default=["standing_fraction", "falls", "time_to_stand", "velocity_error"],
        help="the metrics to print, of those each task has (its first two where it has none of "
        "them)",
    )
    parser.add_argument("--sensing", choices=["robot", "ideal"], default="robot")
    table(parser.parse_args())


if __name__ == "__main__":
    main()
