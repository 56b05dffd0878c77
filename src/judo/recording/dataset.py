"""The collect dataset: a robomimic-style HDF5 file plus judo's plan extras (layout in
docs/collect.md).

    data                      attrs env_args (JSON), total (samples over every demo)
    data/demo_<seed>/obs/qpos       (S, nq)  float64    plant qpos after each step
    data/demo_<seed>/obs/qvel       (S, nv)  float64    plant qvel after each step
    data/demo_<seed>/obs/sensors    (S, nsensordata) float64
    data/demo_<seed>/obs/mocap_pos  (S, 3 * nmocap) float64, only for a task with mocap bodies
    data/demo_<seed>/obs/metadata/<key>  (S, *shape) float64, each key of the task's `recorded_metadata`
    data/demo_<seed>/obs/measured   (S, m)   float64    the measured sensors read (only with --observe sensors)
    data/demo_<seed>/obs/measured_age   (S, k) float64  seconds between taking each measured sensor's value and
                                    the step it was read after (only where the System stamps its readings)
    data/demo_<seed>/obs/estimate_qpos, estimate_qvel   (S, nq), (S, nv) float64, the estimator's state after
                                    each step (only where an estimator ran; NaN rows before it started)
    data/demo_<seed>/actions        (S, nu)  float64    control served during each step
    data/demo_<seed>/mpc_actions    (S, nu)  float64    the MPC's action at each step, where a policy drove
    data/demo_<seed>/policy/...     knots (U, H, nu), inference_ms (U,): the driving policy's chunks
    data/demo_<seed>/rewards        (S,)     float64    the task's reward of each step
    data/demo_<seed>/dones          (S,)     uint8      1 on the last step only
    data/demo_<seed>/limit_hits/... time (K,) float64, limit (K,) bytes, value (K,) float64: each hit of the
                                    [safety] limits' serve filter (only where a limit acted; docs/safety.md)
    data/demo_<seed>/plan/...       times, takes_effect, update_ms, best_reward, mean_reward (U,);
                                    knots (U, num_nodes, nu); traces (U, 1 + num_shown, T, num_trace_sensors,
                                    3) float32, only with --traces and in GUI recordings
                                       (NaN-padded)
    data/demo_<seed>                attrs num_samples, seed, metrics (JSON), success; measured_sensors (JSON
                                    list of the sensor names of obs/measured) with obs/measured
    judo/failed                     attrs "<seed>": why that episode failed (retried on resume)
    judo/dropped                    attrs "<seed>": its metrics (JSON), not a success under --success-only

Only the driver writes, through `DatasetFile`: the file is opened, one finished episode written and
the file closed again, with Ctrl-C held off meanwhile, so the file on disk is always whole. h5py is
imported here only, and this module only where a command needs it.
"""  # noqa: E501

import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.commandline.interrupts import sigint_deferred
from judo.core.errors import JudoError, import_extra

EXTRA = "collect"
"""The optional extra holding h5py and ray."""
LOCK_WAIT_S = 30.0
"""How long a write waits for a reader in another process to let go of the file."""
PLAN_KEYS = ("times", "takes_effect", "update_ms", "best_reward", "mean_reward", "knots")
"""The datasets of a demo's `plan` group."""


class DatasetError(JudoError):
    """A dataset file that cannot be read or written, or that holds episodes of another
    configuration."""


def import_h5py(feature: str = "python -m judo collect") -> Any:
    """The h5py module, or MissingExtraError naming the `collect` extra."""
    return import_extra("h5py", feature, EXTRA)


@dataclass
class EpisodeArrays:
    """One finished episode, as written under `data/demo_<seed>`.

    Attributes:
        seed: the episode's seed.
        qpos, qvel: (S, nq), (S, nv) plant state after each of the S steps.
        sensors: (S, nsensordata) plant sensor values after each step.
        mocap_pos: (S, 3 * nmocap) mocap body positions after each step, or None without mocap
            bodies.
        actions: (S, nu) control served during each step.
        rewards: (S,) the task's reward of each step.
        plan: {"times", "takes_effect", "update_ms", "best_reward", "mean_reward"}: (U,) each, and
            "knots": (U, num_nodes, nu), one row per control update that produced a plan.
        metrics: the task's metrics of the episode.
        success: whether the task counts the episode a success (None: the task has no rule).
        measured: (S, m) the measured sensors the System served after each step, or None (full
            state).
        estimate: (S, nq + nv) the estimator's state after each step (NaN rows where none ran), or
            None.
        measured_sensors: names of the task's measured sensors, in the order of `measured`'s
            columns.
        measured_age: (S, k) for each of the k measured sensors, the seconds between taking the
            value `measured` holds and the end of the step it was read after (0: taken then), or
            None (not stamped).
        mpc_actions: (S, nu) the MPC's action at the time each step was served, where a policy drove
            the plant
            (collect --policy): the label beside `actions`; else None.
        policy_plan: {"knots": (U, H, nu), "inference_ms": (U,)} the policy's chunks, where a policy
            drove.
        metadata: {key: (S, *shape)} each step's system metadata of the
            task's `Task.recorded_metadata` keys
            (e.g. quadruped_velocity's "velocity_command" (S, 3)); empty for a task that declares
            none.
    """

    seed: int
    qpos: np.ndarray
    qvel: np.ndarray
    sensors: np.ndarray
    mocap_pos: np.ndarray | None
    actions: np.ndarray
    rewards: np.ndarray
    plan: dict[str, np.ndarray]
    metrics: dict[str, float]
    success: bool | None
    measured: np.ndarray | None = None
    estimate: np.ndarray | None = None
    measured_sensors: tuple[str, ...] = ()
    mpc_actions: np.ndarray | None = None
    policy_plan: dict[str, np.ndarray] | None = None
    metadata: dict[str, np.ndarray] = field(default_factory=dict)
    measured_age: np.ndarray | None = None
    limit_hits: list[Any] | None = None
    """The serve filter's hits (judo.safety.serve_filter.LimitHit: time, limit, value), where a
    [safety] limit acted."""

    @property
    def num_samples(self) -> int:
        """S, the number of plant steps."""
        return len(self.actions)


def demo_name(seed: int) -> str:
    """The group name of seed `seed`'s episode under `data`."""
    return f"demo_{seed}"


class DatasetFile:
    """The driver's handle on a dataset file: create it, or reopen it to append missing seeds.

    `env_args` is everything that determines the episodes (task, optimizer, configs, versions, model
    hashes); an existing file must hold the same, except for the judo and mujoco versions. Its
    "type" is always "judo", the mark of a file judo wrote: an existing file without it
    (`check_ours`) is refused before it is opened for writing.
    """

    def __init__(self, path: str | Path, env_args: dict[str, Any]) -> None:
        self.h5py = import_h5py()
        self.path = Path(path)
        env_args = {**env_args, "type": "judo"}
        self.env_args = env_args
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            if self.path.exists():
                with self._file("r") as file:
                    check_ours(self.path, file)
            with self._open() as file:
                data = file.require_group("data")
                if "env_args" in data.attrs:
                    check_same_run(self.path, json.loads(data.attrs["env_args"]), env_args)
                else:
                    data.attrs["env_args"] = json.dumps(env_args)
                    data.attrs["total"] = 0
                file.require_group("judo/failed")
                file.require_group("judo/dropped")
        except OSError as err:  # not HDF5, a folder, no permission
            raise DatasetError(f"cannot open {self.path} as an HDF5 dataset: {err}") from None

    @contextmanager
    def _open(self) -> Iterator[Any]:
        with sigint_deferred(), self._file("a") as file:
            yield file
            file.flush()

    def _file(self, mode: str) -> Any:
        """The h5py File in `mode`, waiting up to LOCK_WAIT_S while another process (a reader) holds
        it."""
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                return self.h5py.File(self.path, mode)
            except OSError as err:
                if "lock" not in str(err).lower() or time.monotonic() > deadline:
                    raise DatasetError(f"cannot open {self.path}: {err}") from None
                time.sleep(0.1)

    def finished_seeds(self) -> set[int]:
        """Seeds that need no new episode: kept as a demo, or dropped as not a success."""
        with self._file("r") as file:
            kept = {int(name.removeprefix("demo_")) for name in file["data"]}
            return kept | {int(seed) for seed in file["judo/dropped"].attrs}

    def counts(self) -> dict[str, int]:
        """{"kept", "dropped", "failed", "total"}: demos, dropped and failed seeds, and samples in
        the file."""
        with self._file("r") as file:
            return {
                "kept": len(file["data"]),
                "dropped": len(file["judo/dropped"].attrs),
                "failed": len(file["judo/failed"].attrs),
                "total": int(file["data"].attrs["total"]),
            }

    def write_episode(self, episode: EpisodeArrays) -> None:
        """Add `episode` as data/demo_<seed> (replacing an earlier one of that seed) and update
        `total`."""
        with self._open() as file:
            data = file["data"]
            name = demo_name(episode.seed)
            if name in data:
                data.attrs["total"] = int(data.attrs["total"]) - int(
                    data[name].attrs["num_samples"]
                )
                del data[name]
            write_demo(data.create_group(name), episode)
            data.attrs["total"] = int(data.attrs["total"]) + episode.num_samples
            file["judo/failed"].attrs.pop(str(episode.seed), None)

    def write_failure(self, seed: int, reason: str) -> None:
        """Record that seed `seed`'s episode failed, and why; a resumed run tries it again."""
        with self._open() as file:
            file["judo/failed"].attrs[str(seed)] = reason

    def write_dropped(self, seed: int, metrics: dict[str, float]) -> None:
        """Record that seed `seed`'s episode ran but was not a success (--success-only); it is not
        rerun."""
        with self._open() as file:
            file["judo/dropped"].attrs[str(seed)] = json.dumps(metrics)
            file["judo/failed"].attrs.pop(str(seed), None)


def check_ours(path: Path, file: Any) -> None:
    """DatasetError unless the open h5py `file` is one judo wrote (data.attrs["env_args"] JSON with
    "type" "judo"), or one with nothing in it: judo never writes its groups beside another program's
    data."""
    if not len(file) and not len(file.attrs):
        return
    data = file.get("data")
    env_args = data.attrs.get("env_args") if isinstance(data, import_h5py().Group) else None
    try:
        ours = env_args is not None and json.loads(env_args).get("type") == "judo"
    except (TypeError, ValueError, AttributeError):
        ours = False
    if not ours:
        keys = ", ".join(sorted(file)[:5]) + (", ..." if len(file) > 5 else "")
        raise DatasetError(
            f"{path} is an HDF5 file judo did not write (it holds "
            f"{keys or 'only attributes'} and no judo "
            "env_args); judo writes only into its own datasets: give another file"
        )


def write_demo(group: Any, episode: EpisodeArrays) -> None:
    """Write `episode`'s datasets and attributes into the empty h5py `group`."""
    obs = {"qpos": episode.qpos, "qvel": episode.qvel, "sensors": episode.sensors}
    if episode.mocap_pos is not None:
        obs["mocap_pos"] = episode.mocap_pos
    if episode.measured is not None:
        obs["measured"] = episode.measured
        group.attrs["measured_sensors"] = json.dumps(list(episode.measured_sensors))
        if episode.measured_age is not None:
            obs["measured_age"] = episode.measured_age
    if episode.estimate is not None:
        nq = episode.qpos.shape[1]
        obs["estimate_qpos"], obs["estimate_qvel"] = (
            episode.estimate[:, :nq],
            episode.estimate[:, nq:],
        )
    obs.update({f"metadata/{key}": value for key, value in episode.metadata.items()})
    for key, value in obs.items():
        group.create_dataset(f"obs/{key}", data=np.asarray(value, dtype=np.float64))
    group.create_dataset("actions", data=np.asarray(episode.actions, dtype=np.float64))
    group.create_dataset("rewards", data=np.asarray(episode.rewards, dtype=np.float64))
    if episode.mpc_actions is not None:
        group.create_dataset("mpc_actions", data=np.asarray(episode.mpc_actions, dtype=np.float64))
    for key, value in (episode.policy_plan or {}).items():
        group.create_dataset(f"policy/{key}", data=np.asarray(value, dtype=np.float64))
    dones = np.zeros(episode.num_samples, dtype=np.uint8)
    dones[-1:] = 1
    group.create_dataset("dones", data=dones)
    for key in PLAN_KEYS:
        group.create_dataset(f"plan/{key}", data=np.asarray(episode.plan[key], dtype=np.float64))
    if "traces" in episode.plan:
        group.create_dataset(
            "plan/traces", data=np.asarray(episode.plan["traces"], dtype=np.float32)
        )
    if episode.limit_hits is not None:
        hits = episode.limit_hits
        group.create_dataset(
            "limit_hits/time", data=np.array([hit.time for hit in hits], dtype=np.float64)
        )
        group.create_dataset(
            "limit_hits/limit", data=np.array([hit.limit.encode() for hit in hits], dtype="S")
        )
        group.create_dataset(
            "limit_hits/value", data=np.array([hit.value for hit in hits], dtype=np.float64)
        )
    group.attrs["num_samples"] = episode.num_samples
    group.attrs["seed"] = episode.seed
    group.attrs["metrics"] = json.dumps(episode.metrics)
    group.attrs["success"] = bool(episode.success)


def flatten(content: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dicts as one dict keyed by dotted paths: {"env_kwargs.optimizer.sigma": 0.3, ...}."""
    flat: dict[str, Any] = {}
    for key, value in content.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def check_same_run(path: Path, stored: dict[str, Any], wanted: dict[str, Any]) -> None:
    """DatasetError naming the differing entries unless `stored` and `wanted` env_args agree
    (versions aside)."""
    # hashes count
    ignored = {
        "judo_version",
        "mujoco_version",
        "config_file",
        "policy.file",
        "proposal_policy.file",
    }
    old, new = flatten(stored), flatten(wanted)
    differing = sorted(
        key
        for key in old.keys() | new.keys()
        if key not in ignored and old.get(key) != new.get(key)
    )
    if differing:
        detail = "; ".join(
            f"{key}: file has {old.get(key)!r}, this run {new.get(key)!r}" for key in differing
        )
        raise DatasetError(
            f"{path} holds episodes of another configuration ({detail}); give another --out, "
            "or the same "
            "arguments as the run that made it"
        )
