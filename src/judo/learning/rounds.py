"""distill's driver: train on the datasets, then (with --rounds) let the MPC teach the policy it
made.

Each teacher round r (DAgger; gpc's loop with --proposals):
  1. collect `episodes_per_round` episodes into ROUNDS/round_<r>.h5, seeds from r *
     ROUND_SEED_STRIDE, in which the policy of round r - 1 drives the plant and the dataset's MPC
     labels every state it visits (`collect --policy`; with --proposals K the MPC also samples K
     candidates from the policy);
  2. retrain from scratch on the datasets and every round file so far: ROUNDS/policy_round_<r>.onnx;
  3. measure the policy alone, and the MPC with its proposals, on fresh seeds, and print the table
     so far.
ROUNDS is the folder OUT_rounds beside --out. A rerun with the same settings resumes (RUN_RECORD
holds them; other settings are refused): collect adds only missing seeds, and a round whose policy
file exists is not trained again. The last round's policy is copied to --out at the end, or the last
finished one's on Ctrl-C.
"""

import dataclasses
import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from judo.cli_shared import progress_display
from judo.learning.args import DistillArgs
from judo.learning.export import (
    copy_policy,
    losses_path,
    plot_losses,
    policy_metadata,
    write_policy,
)
from judo.learning.pairs import DistillError, TrainingPairs, read_pairs
from judo.learning.training import TrainedPolicy, train

RUN_RECORD = "distill_run.json"
"""The file in the rounds folder that records the run's settings (`DistillArgs.run_record`), checked
on resume."""
ROUND_SEED_STRIDE = 100_000
"""Round r collects seeds r * ROUND_SEED_STRIDE onwards: never a seed of another round or of a usual
dataset."""


def train_and_write(
    pairs: TrainingPairs, args: DistillArgs, command: str, out: Path, progress_console: Console
) -> TrainedPolicy:
    """Train on `pairs` with a progress bar showing the losses, write the ONNX file and its loss
    PNG."""
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("epoch {task.completed:.0f}"),
    )
    with progress_display(*columns, TimeElapsedColumn(), console=progress_console) as progress:
        bar = progress.add_task(f"training {out.name}", total=args.epochs)

        def show(epoch: int, train_loss: float, validation_loss: float) -> None:
            description = f"{out.name}: loss {train_loss:.4g}, validation {validation_loss:.4g}"
            progress.update(bar, completed=epoch + 1, description=description)

        trained = train(pairs, args.settings(), show)
    write_policy(out, trained, policy_metadata(trained, pairs, command, out.stem), args.noise_scale)
    title = (
        f"{pairs.task}, {pairs.kind} policy, {trained.head}: {pairs.num_pairs} pairs of "
        f"{len(pairs.episodes)} episodes"
    )
    plot_losses(losses_path(out), trained, title)
    return trained


def summary_line(out: Path, trained: TrainedPolicy, pairs: TrainingPairs) -> str:
    """One line on what was trained and where it went."""
    return (
        f"wrote {out} ({pairs.kind}, {trained.head}): {pairs.num_pairs} pairs from "
        f"{len(trained.train_episodes)} "
        f"training and {len(trained.validation_episodes)} validation episodes, "
        f"{len(trained.history['train'])} "
        f"epochs in {trained.seconds:.1f} s, validation loss "
        f"{min(trained.history['validation']):.4g} "
        f"(epoch {trained.best_epoch + 1}); losses in {losses_path(out)}"
    )


def distill(args: DistillArgs, command: str, console: Console, progress_console: Console) -> None:
    """Train on the datasets (and run the teacher rounds), writing `args.out`. Everything that can
    be refused (the datasets, an --out that exists, a resume of other settings, the teacher's flags)
    is refused before any training. Lines that name a file are never wrapped (soft_wrap), so its
    path can be copied whole."""
    datasets = list(args.datasets)
    pairs = read_pairs(datasets, args.kind)
    resuming = args.rounds > 0 and check_resume(args)
    if args.out.exists() and not (args.overwrite or resuming):
        raise DistillError(
            f"--out {str(args.out)!r} exists; give --overwrite to replace it, or another --out"
        )
    if args.rounds == 0:
        trained = train_and_write(pairs, args, command, args.out, progress_console)
        console.print(summary_line(args.out, trained, pairs), soft_wrap=True)
        console.print(
            f"serve it: python -m judo evaluate --task {pairs.task} --policy {args.out}",
            soft_wrap=True,
        )
        return
    env_args = dataset_env_args(datasets[0])
    check_teacher(args, env_args)
    from judo.ray_cluster import start_ray, stop_ray

    # Ray's processes start before JAX trains (and starts its threads), never forked from a JAX
    # process.
    connected = start_ray(args.address, args.workers or os.cpu_count() or 1)
    try:
        teacher_rounds(args, command, pairs, env_args, console, progress_console)
    finally:
        if connected:
            stop_ray()


def teacher_rounds(
    args: DistillArgs,
    command: str,
    pairs: TrainingPairs,
    env_args: dict[str, Any],
    console: Console,
    progress_console: Console,
) -> None:
    """Round 0 on `pairs` (the datasets' own), then --rounds teacher rounds; on Ctrl-C, --out gets
    the last finished round's policy before the interrupt goes on."""
    folder = args.rounds_folder()
    folder.mkdir(parents=True, exist_ok=True)
    (folder / RUN_RECORD).write_text(json.dumps(args.run_record(), indent=1) + "\n")
    datasets = list(args.datasets)
    rows: list[list[str]] = []
    finished: Path | None = None
    policy = folder / "policy_round_0.onnx"
    try:
        for round_index in range(args.rounds + 1):
            if round_index > 0:
                round_file = folder / f"round_{round_index}.h5"
                collect_round(args, env_args, policy, round_file, round_index)
                datasets.append(round_file)
                policy = folder / f"policy_round_{round_index}.onnx"
                pairs = read_pairs(datasets, args.kind)
            if policy.exists():
                console.print(
                    f"round {round_index}: {policy} exists; resumed without training it again",
                    soft_wrap=True,
                )
                seconds = float("nan")
            else:
                trained = train_and_write(pairs, args, command, policy, progress_console)
                console.print(summary_line(policy, trained, pairs), soft_wrap=True)
                seconds = trained.seconds
            finished = policy
            rows.append(
                [str(round_index), str(len(pairs.episodes)), str(pairs.num_pairs), f"{seconds:.1f}"]
            )
            rows[-1] += evaluate_round(args, env_args, policy)
            console.print(round_table(rows, args, env_args))
    except KeyboardInterrupt:
        if finished is not None:
            keep_policy(finished, args.out)
            console.print(
                f"interrupted: wrote {args.out} "
                f"({finished.stem.replace('policy_', '').replace('_', ' ')}'s policy, "
                "the last one finished); the same command resumes the rounds",
                soft_wrap=True,
            )
        raise
    keep_policy(policy, args.out)
    console.print(
        f"wrote {args.out} (round {args.rounds}'s policy); every round's files are in {folder}",
        soft_wrap=True,
    )


def keep_policy(policy: Path, out: Path) -> None:
    """Copy a round's `policy` (and its loss curves) to `out`."""
    copy_policy(policy, out)
    shutil.copyfile(losses_path(policy), losses_path(out))


def check_resume(args: DistillArgs) -> bool:
    """Whether the rounds folder holds rounds of this very run (the same settings,
    `DistillArgs.run_record`), which a rerun resumes. DistillError (one line, naming the settings
    that differ) for rounds of other settings, or of settings that were not recorded; False when
    there are none yet."""
    folder = args.rounds_folder()
    record_path = folder / RUN_RECORD
    if not record_path.is_file():
        if any(folder.glob("policy_round_*.onnx")):
            raise DistillError(
                f"{str(folder)!r} holds teacher rounds whose settings were not recorded, so "
                "they cannot be "
                "resumed; remove it, or give another --out"
            )
        return False
    try:
        recorded = json.loads(record_path.read_text())
    except ValueError:
        recorded = None
    if not isinstance(recorded, dict):
        raise DistillError(
            f"{str(record_path)!r} is not a distill run record; remove {str(folder)!r} to start "
            "again"
        )
    wanted = args.run_record()
    differ = [name for name in wanted if recorded.get(name) != wanted[name]]
    if differ:
        raise DistillError(
            f"{str(folder)!r} holds teacher rounds of {run_flags(recorded, differ)}, not "
            f"{run_flags(wanted, differ)}; "
            "rerun with those to resume them, or give another --out to start new rounds"
        )
    return True


def run_flags(record: dict[str, Any], names: list[str]) -> str:
    """The distill flags that give `record`'s values of `names`, e.g. "--kind action --hidden 16
    16"."""
    parts = []
    for name in names:
        value = record.get(name)
        if name == "datasets":
            parts.append(
                " ".join(map(str, value)) if isinstance(value, list) else "(unrecorded datasets)"
            )
            continue
        shown_value = (
            " ".join(map(str, value))
            if isinstance(value, list)
            else ("(default)" if value is None else value)
        )
        parts.append(f"--{name.replace('_', '-')} {shown_value}")
    return " ".join(parts)


def check_teacher(args: DistillArgs, env_args: dict[str, Any]) -> None:
    """DistillError now, before any training, unless the teacher rounds can run: an optimizer to
    label with, and --proposals below its num_rollouts (the nominal, rollout 0, is never
    replaced)."""
    from judo.core.configuration.registry import lookup_optimizer, make_config

    teacher_flags(args, env_args)
    optimizer = args.optimizer or env_args["optimizer"]
    config_cls = lookup_optimizer(optimizer)[1]
    # teacher_flags passes it on
    rollouts = env_args.get("env_kwargs", {}).get("optimizer", {}).get("num_rollouts")
    if rollouts is None:
        rollouts = make_config(config_cls, env_args["task"], optimizer).num_rollouts
    if args.proposals >= int(rollouts):
        raise DistillError(
            f"--proposals {args.proposals} must be below the teacher's num_rollouts "
            f"({rollouts}, {optimizer} on "
            f"{env_args['task']}): the nominal, rollout 0, is never replaced; expected 0 to "
            f"{int(rollouts) - 1}"
        )


def dataset_env_args(path: Path) -> dict[str, Any]:
    """The env_args of the collect dataset at `path` (read_pairs has checked it is one)."""
    from judo.recording.dataset import import_h5py

    with import_h5py("python -m judo distill").File(path, "r") as file:
        return json.loads(file["data"].attrs["env_args"])


def teacher_flags(args: DistillArgs, env_args: dict[str, Any]) -> list[str]:
    """The collect/evaluate flags that reproduce the dataset's MPC: optimizer, duration, latency,
    and the plan layout fields of its configs (so every round's knots have the dataset's shape)."""
    optimizer = args.optimizer or env_args.get("optimizer")
    if not optimizer:
        raise DistillError(
            "the dataset names no optimizer (a policy drove it); give --optimizer NAME for the "
            "rounds"
        )
    latency = env_args.get("latency_s", 0.0)
    flags = [
        "--task",
        env_args["task"],
        "--optimizer",
        optimizer,
        "--duration",
        repr(float(env_args["duration"])),
    ]
    flags += ["--latency-ms", repr(1e3 * latency if isinstance(latency, (int, float)) else 0.0)]
    kwargs = env_args.get("env_kwargs", {})
    for name in ("control_freq", "horizon", "spline_order"):
        if name in kwargs.get("controller", {}):
            flags += [f"--controller.{name.replace('_', '-')}", str(kwargs["controller"][name])]
    for name in ("num_nodes", "num_rollouts"):
        if name in kwargs.get("optimizer", {}):
            flags += [
                f"--optimizer-config.{name.replace('_', '-')}",
                str(kwargs["optimizer"][name]),
            ]
    return flags


def collect_round(
    args: DistillArgs, env_args: dict[str, Any], policy: Path, out: Path, round_index: int
) -> None:
    """Collect round `round_index`'s episodes (resuming `out`) with `policy` driving and the MPC
    labelling."""
    from judo.collection.collect import main as collect_main

    argv = ["--out", str(out), "--episodes", str(args.episodes_per_round), "--policy", str(policy)]
    argv += ["--first-seed", str(round_index * ROUND_SEED_STRIDE), *teacher_flags(args, env_args)]
    if args.proposals:
        argv += [
            "--proposal-policy",
            str(policy),
            "--controller.policy-samples",
            str(args.proposals),
        ]
    if args.workers is not None:
        argv += ["--workers", str(args.workers)]
    if args.address is not None:
        argv += ["--address", args.address]
    status = collect_main(argv)
    if status == 130:  # collect was interrupted (Ctrl-C); the rounds stop the same way
        raise KeyboardInterrupt
    if status:
        raise DistillError(
            f"round {round_index}'s collect ended with status {status}; rerun to resume it"
        )


def proposal_samples(env_args: dict[str, Any]) -> int:
    """K for the table's "MPC + proposals" column: an eighth of the MPC's rollouts, at least 1."""
    rollouts = int(env_args.get("env_kwargs", {}).get("optimizer", {}).get("num_rollouts", 16))
    return max(1, rollouts // 8)


def evaluate_round(args: DistillArgs, env_args: dict[str, Any], policy: Path) -> list[str]:
    """The round's two table cells: the task's metric for the policy alone and for the MPC with its
    proposals, mean over `args.eval_seeds` fresh seeds ("-" with --eval-seeds 0)."""
    if args.eval_seeds == 0:
        return ["-", "-"]
    from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode

    optimizer = args.optimizer or env_args.get("optimizer")
    latency = env_args.get("latency_s", 0.0)
    latency = float(latency) if isinstance(latency, (int, float)) else 0.0
    base = EpisodeSpec(
        env_args["task"], None, float(env_args["duration"]), latency, num_workers=None
    )
    with_proposals = dataclasses.replace(
        base,
        optimizer=optimizer,
        proposal_policy=str(policy),
        values={"controller.policy_samples": proposal_samples(env_args)},
    )
    specs = {
        "policy": dataclasses.replace(base, policy=str(policy)),
        "proposals": with_proposals if with_proposals.runs_mpc else None,
    }
    cells = []
    seeds = range(args.eval_first_seed, args.eval_first_seed + args.eval_seeds)
    for spec in specs.values():
        if spec is None:
            cells.append("-")
            continue
        results = [run_seeded_episode(spec, seed) for seed in seeds]
        metric = headline_metric(results[0].metrics)
        values = np.array([result.metrics[metric] for result in results])
        cells.append(f"{metric} {values.mean():.3g}")
    return cells


def headline_metric(metrics: dict[str, float]) -> str:
    """The task's own first metric (not mean_reward, unless it is the only one)."""
    return next((name for name in metrics if name != "mean_reward"), "mean_reward")


def round_table(rows: list[list[str]], args: DistillArgs, env_args: dict[str, Any]) -> Table:
    """The rounds so far: data, training time, and the two measurements on fresh seeds."""
    seeds = f"measured on seeds {args.eval_first_seed}-{args.eval_first_seed + args.eval_seeds - 1}"
    if args.eval_seeds < 1:
        seeds = "not measured (--eval-seeds 0)"
    table = Table(
        title=f"distill {env_args['task']} ({args.kind}, {args.head}): teacher rounds, {seeds}"
    )
    for column in ("round", "episodes", "pairs", "training s", "policy alone"):
        table.add_column(column, justify="right")
    table.add_column(f"MPC + proposals (K = {proposal_samples(env_args)})", justify="right")
    for row in rows:
        table.add_row(*row)
    return table
