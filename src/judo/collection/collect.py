"""`python -m judo collect`: closed-loop MPC episodes, seeded F..F+N-1 (--first-seed F, 0 by
default), run as Ray tasks into an HDF5 dataset.

python -m judo collect --task cartpole --optimizer mppi --episodes 100 --duration 10 --out cartpole.h5
"""  # noqa: E501

import hashlib
import os
import shlex
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import mujoco
import tyro

from judo.cli_shared import fail, name_listing, parse_args_with_config_fields
from judo.core.commandline.boundary import check_seed_range
from judo.core.configuration.config import Config, require, require_between
from judo.core.errors import JudoError
from judo.evaluation.episode_args import EpisodeArgs
from judo.recording.model_info import config_dict, model_sha256
from judo.version import __version__

DESCRIPTION = (
    "Collect closed-loop MPC episodes of a task x optimizer into an HDF5 dataset in a "
    "robomimic-style layout "
    "(data/demo_<seed>/obs/qpos, actions, rewards, dones, ...) plus each control update's "
    "plan (docs/collect.md). "
    "Episodes are seeded --first-seed to --first-seed + --episodes - 1 (0 to --episodes - 1 "
    "by default) and run as Ray tasks, on a local Ray (--workers) or a cluster "
    "(--address). The same command again adds only the seeds missing from --out, so a larger "
    "--episodes extends "
    "a file and an interrupted run resumes; Ctrl-C keeps every finished episode. Config "
    "fields of the pair are "
    "set with --controller.FIELD, --optimizer-config.FIELD and --task-config.FIELD (listed "
    "below once --task and "
    "--optimizer are given). With --observe sensors (and --sensor-*, --estimator) the file "
    "also holds what the "
    "robot measured and what the estimator estimated. Needs the `collect` extra: pip install "
    "-e '.[collect]'."
)


@dataclass
class CollectArgs(EpisodeArgs):
    """Arguments of `python -m judo collect`."""

    out: Annotated[Path, tyro.conf.arg(metavar="FILE.h5")] = field(kw_only=True)
    """The HDF5 dataset to write; an existing one made with the same arguments gets the missing
    seeds."""
    episodes: int = 10
    """Episodes the file should hold, with seeds first_seed to first_seed + episodes - 1."""
    first_seed: int = 0
    """Seed of the first episode (e.g. 1000, to keep a policy's evaluation seeds out of its training
    data). Not part of the run's identity: the same command with another --first-seed adds those
    seeds to the same file, which can so hold seeds 0-9 and 100-109."""
    duration: float = 10.0
    """Length of each episode in seconds of sim time."""
    success_only: bool = False
    """Keep only the episodes the task counts as a success (Task.success of its metrics); the others
    are listed in the file as dropped and not run again."""
    traces: bool = False
    """Also keep each plan's traces (plan/traces: the trace sensors along the nominal and best
    rollouts, drawn by replay); off by default, as they are most of a file's size."""
    workers: Annotated[
        int | None, tyro.conf.arg(metavar="N", help_behavior_hint="(default: one per core)")
    ] = None
    """Episodes run at once, each on one rollout thread (the CPUs of a local Ray; with --address,
    default twice the cluster's CPUs in flight)."""
    address: Annotated[
        str | None, tyro.conf.arg(metavar="ADDRESS", help_behavior_hint="(default: a local Ray)")
    ] = None
    """A running Ray cluster: auto (the one `ray start --head` started on this machine) or
    ray://HOST:10001."""
    # EpisodeArgs has the task, optimizer, --config, latency, backend, --controller.FIELD and
    # sensing options.

    def validate(self) -> None:
        """Raise a JudoError for an argument out of range or a name that is not registered."""
        self.check()
        require_between("--episodes", self.episodes, 1, 10_000_000)
        check_seed_range(self.first_seed, self.episodes, "--episodes")
        require(
            self.workers is None or self.workers >= 1,
            f"--workers must be at least 1, got {self.workers}",
        )
        require(
            self.out.suffix in (".h5", ".hdf5"),
            f"--out must name an .h5 or .hdf5 file, got {str(self.out)!r}",
        )
        if self.policy is not None:
            require(
                self.runs_mpc,
                "collect --policy needs --optimizer NAME: the MPC that plans from the states "
                "the policy visits, "
                "for the labels",
            )
            require(
                self.latency != "measured",
                "collect --policy with --latency measured would count the MPC's labelling in "
                "the policy's latency; "
                "give --latency-ms MS",
            )


def env_args(args: CollectArgs, configs: dict[Any, Config]) -> dict[str, Any]:
    """The `data` group's env_args: everything that determines the episodes, plus versions and model
    hashes."""
    from judo.core.configuration.registry import make_task

    task = make_task(args.task)
    latency = args.episode_latency()
    return {
        "env_name": args.task,
        "type": "judo",
        "task": args.task,
        "optimizer": args.optimizer,
        "policy": None if args.policy is None else policy_record(args),
        "proposal_policy": None
        if args.proposal_policy is None
        else file_record(args.proposal_policy),
        "duration": args.duration,
        "latency_s": latency,
        "sensing": args.sensing_record(),
        "backend": args.backend,
        "success_only": args.success_only,
        "traces": args.traces,
        "config_file": None if args.config is None else str(args.config),
        "env_kwargs": {kind: config_dict(config) for kind, config in configs.items()},
        "plant_timestep": float(task.sim_model.opt.timestep),
        "judo_version": __version__,
        "mujoco_version": mujoco.__version__,
        "planning_model_sha256": model_sha256(task.model),
        "plant_model_sha256": model_sha256(task.sim_model),
    }


def file_record(path: Path) -> dict[str, str]:
    """A policy file in env_args: its absolute path and SHA-256 (another file is another run)."""
    return {"file": str(path.resolve()), "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


def policy_record(args: CollectArgs) -> dict[str, Any]:
    """The driving policy in env_args: its file, the file's SHA-256 (another policy is another run),
    its name, horizon and metadata, and the ControllerConfig it was served under."""
    from judo.core.policies.policy_controller import as_policy
    from judo.evaluation.seeded import policy_config_in_force

    assert args.policy is not None, "env_args records a policy only when --policy is given"
    path = Path(args.policy)
    policy = as_policy(path)
    return {
        "file": str(path.resolve()),
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        "name": policy.name,
        "horizon": policy.horizon,
        "metadata": dict(policy.metadata),
        "controller": config_dict(policy_config_in_force(args.spec(1), policy)),
    }


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo collect` on `argv` (sys.argv[1:] when None); exits with status 2 on bad
    arguments."""
    from judo.collection.run import collect
    from judo.core.configuration.config_values import controller_config_of
    from judo.evaluation.seeded import configs_in_force, load_proposal_policy
    from judo.recording.dataset import import_h5py

    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args_with_config_fields(
        CollectArgs, argv, "python -m judo collect", DESCRIPTION + " " + name_listing()
    )
    try:
        # every argument, sensing flags included, before Ray starts or a file is opened
        args.validate()
        import_h5py()
        from judo.ray_cluster import import_ray

        import_ray("python -m judo collect", "collect")
        spec = args.spec(num_workers=1)
        configs = configs_in_force(spec)
        load_proposal_policy(spec.proposal_policy, controller_config_of(configs).policy_samples)
        command = "python -m judo collect " + shlex.join(argv)
        return collect(
            spec, env_args(args, configs), args, command, args.workers or os.cpu_count() or 1
        )
    except JudoError as err:
        fail(str(err))
