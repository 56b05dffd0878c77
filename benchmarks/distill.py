"""distill, measured: the MPC, its distilled policy (round 0 and after teacher rounds), and the MPC
at N/8 rollouts with and without the policy's proposals, each on fresh seeds that no training
episode used.

For each task: collect --episodes MPC episodes (seeds 0 .. episodes - 1) into WORKDIR/TASK.h5;
distill a chunk policy with --rounds teacher rounds (round r collects seeds from r * 100000); then
every column below runs
--seeds episodes from --first-seed (default 1000) in sim time. Reruns reuse WORKDIR's files (collect
and distill resume). Prints one markdown table of the task's own metric, with each column's share of
the MPC's, and the policy's inference time against the MPC's update time, the training time and the
episodes used.

    PYTHONPATH=src python benchmarks/distill.py --tasks cartpole pendulum particle --episodes 30 --rounds 3
"""  # noqa: E501

import json
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import tyro

from judo.collection.collect import main as collect_main
from judo.core.configuration.registry import lookup_optimizer, make_config
from judo.core.policies.onnx_policy import OnnxPolicy
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.learning.distill import main as distill_main
from judo.learning.rounds import headline_metric


@dataclass
class Args:
    """Which tasks, how much data, how many teacher rounds, and which fresh seeds."""

    tasks: list[str] = field(
        default_factory=lambda: [
            "cartpole",
            "pendulum",
            "acrobot",
            "double_cartpole",
            "particle",
            "push_t",
        ]
    )
    """Tasks, by registered name."""
    optimizer: str = "mppi"
    """The MPC that makes the data and labels the rounds."""
    episodes: int = 30
    """MPC episodes collected per task before distilling."""
    duration: float = 10.0
    """Seconds of sim time per episode (collected and measured)."""
    rounds: int = 3
    """Teacher rounds after round 0."""
    episodes_per_round: int = 10
    """Episodes each round collects."""
    kind: str = "chunk"
    """The policy's kind (chunk: it serves alone and as proposals)."""
    head: str = "regression"
    """The distilled head: regression or flow."""
    seeds: int = 5
    """Fresh seeds per column."""
    first_seed: int = 1000
    """The first fresh seed (training used 0 .. episodes - 1 and the rounds' r * 100000 ..)."""
    workers: int = 2
    """Episodes collected at once (a local Ray)."""
    workdir: Path = Path("distill_runs")
    """Where the datasets and policies go (and are reused from)."""


def measure(spec: EpisodeSpec, seeds: range) -> tuple[dict[str, float], float]:
    """({metric: mean over seeds}, median update ms) of `spec` on `seeds`."""
    results = [run_seeded_episode(spec, seed) for seed in seeds]
    names = list(results[0].metrics)
    means = {name: float(np.mean([r.metrics[name] for r in results])) for name in names}
    return means, float(np.median(np.concatenate([r.update_ms for r in results])))


def run_task(task: str, args: Args) -> dict:
    """Collect, distill and measure one task; returns its row."""
    args.workdir.mkdir(parents=True, exist_ok=True)
    data, policy = (
        args.workdir / f"{task}.h5",
        args.workdir / f"{task}_{args.kind}_{args.head}.onnx",
    )
    started = time.perf_counter()
    collect_main(["--task", task, "--optimizer", args.optimizer, "--episodes", str(args.episodes), "--duration",  # noqa: E501
                  str(args.duration), "--out", str(data), "--workers", str(args.workers)])  # fmt: skip  # noqa: E501
    collect_s = time.perf_counter() - started
    started = time.perf_counter()
    distill_main([str(data), "--out", str(policy), "--kind", args.kind, "--head", args.head, "--rounds",  # noqa: E501
                  str(args.rounds), "--episodes-per-round", str(args.episodes_per_round), "--eval-seeds", "0",  # noqa: E501
                  "--workers", str(args.workers)])  # fmt: skip
    distill_s = time.perf_counter() - started
    rounds = policy.with_name(policy.stem + "_rounds")
    first = rounds / "policy_round_0.onnx" if args.rounds else policy
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    n = make_config(lookup_optimizer(args.optimizer)[1], task, args.optimizer).num_rollouts  # type: ignore[attr-defined]
    small, k = max(2, n // 8), max(1, n // 16)
    mpc = EpisodeSpec(task, args.optimizer, args.duration, num_workers=None)
    few = {"optimizer.num_rollouts": small}
    specs = {
        "MPC": mpc,
        "policy, round 0": replace(mpc, optimizer=None, policy=str(first)),
        f"policy, round {args.rounds}": replace(mpc, optimizer=None, policy=str(policy)),
        f"MPC + policy, N/8 (K={k})": replace(mpc, values={**few, "controller.policy_samples": k}, proposal_policy=str(policy)),  # noqa: E501
        "MPC, N/8": replace(mpc, values=few),
    }  # fmt: skip
    row = {
        "task": task,
        "N": n,
        "N/8": small,
        "collect_s": collect_s,
        "distill_s": distill_s,
        "columns": {},
    }
    for label, spec in specs.items():
        metrics, update_ms = measure(spec, seeds)
        row["columns"][label] = {"metrics": metrics, "update_ms": update_ms}
    row["metric"] = headline_metric(row["columns"]["MPC"]["metrics"])
    metadata = OnnxPolicy(policy).metadata
    row["training_s"], row["episodes_used"] = (
        float(metadata["training_seconds"]),
        args.episodes + args.rounds * args.episodes_per_round,
    )
    return row


def print_table(rows: list[dict], args: Args) -> None:
    """The figures as markdown: the metric (its share of the MPC's), then the timings."""
    labels = list(rows[0]["columns"])
    print(f"\n### distill ({args.kind}, {args.head}, {args.optimizer}; {args.seeds} fresh seeds "
          f"from {args.first_seed} x "
          f"{args.duration:g} s; {args.episodes} MPC episodes + {args.rounds} rounds x "
          f"{args.episodes_per_round})\n")  # fmt: skip
    print("| task | metric | " + " | ".join(labels) + " |")
    print("|---|---|" + "---|" * len(labels))
    for row in rows:
        metric, base = row["metric"], row["columns"]["MPC"]["metrics"][row["metric"]]
        cells = []
        for label in labels:
            value = row["columns"][label]["metrics"][metric]
            share = f" ({value / base:.2f})" if base > 0 else ""
            cells.append(f"{value:.3g}{share}")
        print(f"| {row['task']} | {metric} | " + " | ".join(cells) + " |")
    print(
        "\n| task | policy inference µs | MPC update ms (N) | training s (last round) | "
        "episodes used | collect + distill min |"
    )
    print("|---|---|---|---|---|---|")
    for row in rows:
        inference = 1e3 * row["columns"]["policy, round 0"]["update_ms"]
        print(f"| {row['task']} | {inference:.0f} | {row['columns']['MPC']['update_ms']:.1f} "
              f"({row['N']}) | "
              f"{row['training_s']:.0f} | {row['episodes_used']} | "
              f"{(row['collect_s'] + row['distill_s']) / 60:.1f} |")  # fmt: skip


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    rows = [run_task(task, args) for task in args.tasks]
    (args.workdir / "figures.json").write_text(json.dumps(rows, indent=2))
    print_table(rows, args)


if __name__ == "__main__":
    main()
