"""A policy as the controller: its inference time per control update against the MPC's update time,
same task.

For each task, seeded closed-loop episodes (the ones `python -m judo evaluate` runs) driven by
  - a linear policy (a = W o + b, one Gemm) and an MLP (two hidden layers of --hidden, tanh), both
    ONNX files written here with the onnx helper API and run on onnxruntime's CPU provider (one
    thread), their weights random: the figure is the time, not the behaviour;
  - the optimizer, at the task's defaults.
Each row gives the median wall time of one control update as the closed loop measures it (for a
policy: the task's observation, one `act` and the plan; for the optimizer: one planning cycle) and
how many policy updates fit in one MPC update. Wall times on a shared machine vary; compare rows of
one run.

PYTHONPATH=src python benchmarks/policy_controller.py [--tasks cartpole acrobot] [--optimizer mppi]
[--seeds 2]
"""

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import tyro
from rich.console import Console
from rich.table import Table

import judo
from judo.cli_shared import seeds_label
from judo.core.policies.onnx_policy import write_linear_policy, write_mlp_policy
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode


@dataclass
class Args:
    """Which tasks, which optimizer, how many episodes."""

    tasks: list[str] = field(default_factory=lambda: ["cartpole", "acrobot"])
    """Tasks, by registered name."""
    optimizer: str = "mppi"
    """The optimizer the policies are compared with, by registered name."""
    seeds: int = 2
    """Episodes per controller, seeds first_seed to first_seed + seeds - 1."""
    first_seed: int = 0
    """Seed of each controller's first episode."""
    duration: float = 5.0
    """Seconds of sim time per episode."""
    hidden: int = 64
    """Width of the MLP's two hidden layers."""


def write_policies(task_name: str, folder: Path, hidden: int) -> dict[str, Path]:
    """{"linear": path, "mlp HxH": path}: random policies sized for the task, made for it."""
    task = judo.make_controller(task_name, "ps").task
    size, nu = task.policy_observation_size(), task.nu
    rng = np.random.default_rng(0)
    metadata = {"task": task_name}
    layers = [
        (0.1 * rng.standard_normal((hidden, size)), np.zeros(hidden)),
        (0.1 * rng.standard_normal((hidden, hidden)), np.zeros(hidden)),
        (0.01 * rng.standard_normal((nu, hidden)), np.zeros(nu)),
    ]
    return {
        "linear": write_linear_policy(
            folder / f"{task_name}_linear.onnx", np.zeros((nu, size)), metadata=metadata
        ),
        f"mlp {hidden}x{hidden}": write_mlp_policy(
            folder / f"{task_name}_mlp.onnx", layers, metadata=metadata
        ),
    }


def median_update_ms(spec: EpisodeSpec, seeds: range) -> tuple[float, int]:
    """(median update wall time in ms, number of updates) over the episodes of `seeds`."""
    update_ms = np.concatenate([run_seeded_episode(spec, seed).update_ms for seed in seeds])
    return float(np.median(update_ms)), len(update_ms)


def main(args: Args) -> None:
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    label = seeds_label(args.first_seed, args.seeds)
    table = Table(
        title=f"policy inference vs {args.optimizer} update ({label} x {args.duration:g} s)"
    )
    for column in ("task", "controller", "updates", "median per update", "per MPC update"):
        table.add_column(column, justify="left" if column in ("task", "controller") else "right")
    with tempfile.TemporaryDirectory() as folder:
        for task in args.tasks:
            mpc_ms, mpc_updates = median_update_ms(
                EpisodeSpec(task, args.optimizer, args.duration), seeds
            )
            for label, path in write_policies(task, Path(folder), args.hidden).items():
                spec = EpisodeSpec(task, None, args.duration, policy=str(path))
                ms, updates = median_update_ms(spec, seeds)
                table.add_row(
                    task,
                    f"policy ({label})",
                    str(updates),
                    f"{1e3 * ms:.1f} µs",
                    f"{mpc_ms / ms:.0f}x",
                )
            table.add_row(task, args.optimizer, str(mpc_updates), f"{mpc_ms:.2f} ms", "1x")
    Console(width=120).print(table)


if __name__ == "__main__":
    main(tyro.cli(Args))
