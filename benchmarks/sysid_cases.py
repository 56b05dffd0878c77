"""System identification on simulated plants with known wrong parameters: log, fit, plan with the fit.

For each case: the plant differs from the planning model by known parameters (--plant-overrides); a closed-loop
MPC episode on it is logged (collect's HDF5 file, planning with the wrong model); `python -m judo sysid`'s fit
(mujoco.sysid over K-step windows) recovers the parameters; then closed-loop episodes on fresh seeds plan with the
true model, the wrong one and the fitted one ([model_overrides]), on the same mismatched plant.

    PYTHONPATH=src python benchmarks/sysid_cases.py --cases cartpole leap_cube

Prints one Markdown row per fitted parameter: the true value, the planning model's, the fitted one, the K-step
prediction error before and after, the closed-loop metric (true / wrong / fitted model, and the share of what the
wrong model lost that the fitted one recovers) and the fit's wall time.
"""

import argparse
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judo.collection.dataset import DatasetFile
from judo.collection.episode import collect_episode
from judo.collection.sysid import fit, parse_parameters, read_logs
from judo.core import registry
from judo.core.model_overrides import check_model_overrides, model_value, parse_override_entries
from judo.core.registry import make_task, set_model_overrides
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode


@dataclass(frozen=True)
class Case:
    """A task, its plant's true parameters, the parameters fitted and the closed-loop metric compared."""

    task: str
    optimizer: str
    plant: tuple[str, ...]
    params: tuple[str, ...]
    metric: str
    duration: float
    """Seconds of each closed-loop episode compared."""


CASES = {
    "cartpole": Case(
        "cartpole",
        "mppi",
        ("body_mass.pole=0.13", "dof_damping.slider=0.005"),
        ("body_mass.pole", "dof_damping.slider"),
        "mean_reward",
        10.0,
    ),
    "leap_cube": Case(
        "leap_cube",
        "mppi",
        ("opt.o_friction=[0.9, 0.9, 0.02, 0.0001, 0.0001]",),
        ("opt.o_friction[0]", "opt.o_friction[1]"),
        "goals_per_minute",
        20.0,
    ),
}


def closed_loop(case: Case, overrides: dict | None, seeds: range) -> float:
    """Mean `case.metric` over `seeds` on the mismatched plant, planning with `overrides` (None: the MJCF's)."""
    registry._MODEL_OVERRIDES.pop((case.task, False), None)
    if overrides:
        set_model_overrides(case.task, overrides)
    spec = EpisodeSpec(case.task, case.optimizer, case.duration, plant_overrides=case.plant)
    values = [run_seeded_episode(spec, seed).metrics[case.metric] for seed in seeds]
    registry._MODEL_OVERRIDES.pop((case.task, False), None)
    return float(np.mean(values))


def run_case(name: str, case: Case, args: argparse.Namespace, folder: Path) -> list[str]:
    """The case's table rows."""
    log = folder / f"{name}.h5"
    spec = EpisodeSpec(case.task, case.optimizer, args.log_seconds, plant_overrides=case.plant)
    outcome = collect_episode(spec, args.log_seed)
    assert outcome.failure is None, outcome.failure
    task = make_task(case.task)
    env_args = {"task": case.task, "optimizer": case.optimizer, "plant_timestep": float(task.sim_model.opt.timestep)}
    DatasetFile(log, env_args).write_episode(outcome.episode)
    parameters = parse_parameters(case.params, task.model)
    episodes = read_logs([log], case.task, task.model)
    steps = round(args.window / float(task.model.opt.timestep))
    result = fit(task, parameters, episodes, steps, args.max_iters)
    truth_overrides = check_model_overrides(task.model, parse_override_entries(case.plant))
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    true_metric = closed_loop(case, truth_overrides, seeds)
    wrong_metric = closed_loop(case, None, seeds)
    fitted_metric = closed_loop(case, result.overrides(task.model), seeds)
    lost = true_metric - wrong_metric
    recovered = f"{(fitted_metric - wrong_metric) / lost:.0%}" if abs(lost) > 1e-9 else "n/a (nothing lost)"
    rows = []
    for index, parameter in enumerate(parameters):
        truth = truth_overrides.get(parameter.field, {}).get(parameter.element)
        true_value = float(truth[parameter.index or 0]) if truth is not None else float("nan")
        planning = float(model_value(task.model, parameter.field, parameter.element)[parameter.index or 0])
        if parameter.field == "opt" and not task.model.opt.enableflags & 8:  # mjENBL_OVERRIDE off: unused
            planning_text = f"{planning:.4g} (override off)"
        else:
            planning_text = f"{planning:.4g}"
        fitted = f"{result.fitted[index]:.4g}" + ("" if result.excited[index] else " (not excited)")
        error = abs(result.fitted[index] - true_value) / abs(true_value)
        closed = f"{true_metric:.3g} / {wrong_metric:.3g} / {fitted_metric:.3g} ({recovered} recovered)"
        rows.append(
            f"| {name} | {parameter.name} | {true_value:.4g} | {planning_text} | {fitted} ({error:.1%} off) | "
            f"{result.error_before:.3g} / {result.error_after:.3g} | "
            + (f"{case.metric}: {closed} | {result.seconds:.1f} s |" if index == 0 else "| |")
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=sorted(CASES))
    parser.add_argument("--log-seconds", type=float, default=60.0, help="seconds of the logged closed loop")
    parser.add_argument("--log-seed", type=int, default=500, help="seed of the logged episode")
    parser.add_argument("--seeds", type=int, default=5, help="closed-loop episodes per model")
    parser.add_argument("--first-seed", type=int, default=1000, help="fresh seeds, apart from the log's")
    parser.add_argument("--window", type=float, default=0.05, help="seconds of each fitted window (sysid --window)")
    parser.add_argument("--max-iters", type=int, default=50)
    args = parser.parse_args()
    print(
        f"{args.log_seconds:g} s logged (seed {args.log_seed}); closed loop on seeds {args.first_seed} to "
        f"{args.first_seed + args.seeds - 1}; windows of {args.window:g} s\n"
    )
    print(
        "| case | parameter | true | planning model | fitted | k-step prediction error before / after | "
        "closed-loop metric: true model / wrong / fitted | fit time |"
    )
    print("|---|---|---|---|---|---|---|---|", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        for name in args.cases:
            started = time.perf_counter()
            for row in run_case(name, CASES[name], args, Path(folder)):
                print(row, flush=True)
            print(f"<!-- {name}: {time.perf_counter() - started:.0f} s wall -->", flush=True)


if __name__ == "__main__":
    main()
