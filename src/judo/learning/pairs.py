"""Training pairs from collect's datasets: what the policy saw, and what the MPC did there.

Two kinds of policy (judo.core.policy.POLICY_KINDS):
  - "action": the observation of the state after step s gives the action served in step
    s + 1 (`actions`, or
    `mpc_actions`, the MPC's label, where a policy drove the plant);
  - "chunk": the observation of the state at each control update's reading gives that plan's knots
    (`plan/knots`, (num_nodes, nu)), which is what gpc learns. An update at time t reads the state
    after step round(t / dt) - 1; the first update (t = 0, before any step) has no recorded state
    and is left out.

Observations are the task's own `policy_observation`, built exactly as the closed loop builds them
when it serves a policy: the planning model's sensors at the state (where the task reads sensors),
the goal's mocap position of that step, the system metadata the task
records (`Task.recorded_metadata`, `obs/metadata/<key>`: e.g. quadruped_velocity's command) of that
step, and the action in force as the previous action. They are of the plant's true state: where an
episode ran an estimator, the policy learns from the state the estimator was estimating.
"""

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import JudoError
from judo.core.reading import model_at
from judo.core.task import Task

FEATURE = "python -m judo distill"


class DistillError(JudoError):
    """A dataset that cannot be trained on (missing, corrupt, empty, of another task), or a bad
    distill argument."""


@dataclass
class TrainingPairs:
    """Observation and target rows of every episode read, kept per episode for a split by episode.

    Attributes:
        task: the registered task the datasets were collected on.
        kind: "action" or "chunk".
        observations: [(n_i, O)] one array per episode.
        targets: [(n_i, H * A)] one array per episode: the action (H = 1) or the plan's knots,
            flattened.
        episodes: ["FILE:demo_<seed>"] naming each episode.
        horizon, action_size: H and A of a target row.
        controller: the MPC's ControllerConfig fields the policy should be served
            with ("control_freq", and for a chunk "horizon" and "spline_order"), as strings for the
            ONNX metadata.
        observation_layout: what the observation's columns are, for the ONNX metadata.
    """

    task: str
    kind: str
    observations: list[np.ndarray] = field(default_factory=list)
    targets: list[np.ndarray] = field(default_factory=list)
    episodes: list[str] = field(default_factory=list)
    horizon: int = 1
    action_size: int = 0
    controller: dict[str, str] = field(default_factory=dict)
    observation_layout: str = ""

    @property
    def num_pairs(self) -> int:
        """Rows over every episode."""
        return int(sum(len(rows) for rows in self.observations))


def episode_observations(
    task: Task,
    states: np.ndarray,
    mocap_pos: np.ndarray | None,
    previous: np.ndarray,
    time_step: float,
    recorded: dict[str, np.ndarray] | None = None,
) -> np.ndarray:
    """(S, O) the task's `policy_observation` of S recorded rows, as the closed loop builds them.

    Args:
        task: the planning task.
        states: (S, nq + nv) [qpos, qvel] after each step.
        mocap_pos: (S, 3 * nmocap) the mocap positions of each step, or None without mocap bodies.
        previous: (S, nu) the action in force at each row (served during that step).
        time_step: the plant's timestep (row r is at time (r + 1) * time_step).
        recorded: {key: (S, *shape)} the system metadata of each step (`obs/metadata`), given to the
            observation as the row's `system_metadata[key]` (*shape).
    """
    model = task.model
    bodies = np.flatnonzero(model.body_mocapid >= 0)
    bodies = bodies[np.argsort(model.body_mocapid[bodies])]
    wants_sensors = type(task).policy_observation is not Task.policy_observation
    data = mujoco.MjData(model)
    rows = np.zeros((len(states), 0))
    recorded = recorded or {}
    columns = [
        np.asarray(values, dtype=float).reshape(len(states), -1) for values in recorded.values()
    ]
    if mocap_pos is not None and len(bodies):
        columns.append(np.asarray(mocap_pos, dtype=float).reshape(len(states), -1))
    groups = [np.arange(len(states))]
    if columns and len(states):  # rows with the same goal and metadata go in one batch
        _, inverse = np.unique(np.concatenate(columns, axis=1), axis=0, return_inverse=True)
        groups = [np.flatnonzero(inverse.ravel() == k) for k in range(int(inverse.max()) + 1)]
    for index in groups:
        metadata: dict[str, Any] | None = None
        if len(bodies):
            positions = (
                model.body_pos[bodies] if mocap_pos is None else mocap_pos[index[0]].reshape(-1, 3)
            )
            metadata = {"mocap_pos": positions.copy(), "mocap_quat": model.body_quat[bodies].copy()}
        if recorded:
            metadata = {
                **(metadata or {}),
                **{key: values[index[0]].copy() for key, values in recorded.items()},
            }
        sensors = None
        if wants_sensors:
            sensors = np.zeros((len(index), model.nsensordata))
            for j, row in enumerate(index):
                sensors[j] = model_at(
                    model, data, states[row], (row + 1) * time_step, metadata
                ).sensordata
        block = np.asarray(
            task.policy_observation(states[index], sensors, metadata, previous[index]), dtype=float
        )
        if rows.shape[1] != block.shape[1]:
            rows = np.zeros((len(states), block.shape[1]))
        rows[index] = block
    return rows


def recorded_metadata(path: Path, name: str, demo: Any, task: Task) -> dict[str, np.ndarray]:
    """{key: (S, *shape)} the demo's `obs/metadata/<key>` of each of the task's `recorded_metadata`
    keys that its own `policy_observation` may read (none for the default observation, the state).
    DistillError (one line) for a key the file lacks (a file collected before judo kept it) or of
    another length."""
    if type(task).policy_observation is Task.policy_observation:
        return {}
    rows, recorded = len(demo["obs/qpos"]), {}
    for key in task.recorded_metadata:
        if f"obs/metadata/{key}" not in demo:
            raise DistillError(
                f"{str(path)!r} {name} has no obs/metadata/{key}, the system metadata "
                f"{type(task).__name__}'s "
                "observation reads; collect the dataset again with this judo, which records it"
            )
        recorded[key] = demo[f"obs/metadata/{key}"][()]
        if len(recorded[key]) != rows:
            raise DistillError(
                f"{str(path)!r} {name}: obs/metadata/{key} has {len(recorded[key])} rows, "
                f"obs/qpos {rows}"
            )
    return recorded


def observation_layout(task: Task) -> str:
    """What the task's observation columns are, for the policy's metadata: [qpos, qvel] by default,
    else the first line of the task's own `policy_observation` docstring."""
    if type(task).policy_observation is Task.policy_observation:
        return f"[qpos ({task.model.nq}), qvel ({task.model.nv})]"
    return (type(task).policy_observation.__doc__ or type(task).__name__).strip().splitlines()[0]


def read_pairs(paths: list[Path], kind: str) -> TrainingPairs:
    """The training pairs of every episode in the collect datasets `paths` (all of one task).

    Raises DistillError (one line) for a missing, unreadable, foreign or empty file, files of
    different tasks or plan layouts, and a "chunk" request on files without `plan/knots`.
    """
    from judo.recording.dataset import import_h5py

    h5py = import_h5py(FEATURE)
    pairs: TrainingPairs | None = None
    for path in paths:
        if not path.is_file():
            raise DistillError(
                f"dataset {str(path)!r} does not exist; give files written by python -m judo "
                "collect"
            )
        try:
            with h5py.File(path, "r") as file:
                pairs = _read_file(path, file, kind, pairs)
        except OSError as err:
            raise DistillError(
                f"cannot read {str(path)!r} as an HDF5 dataset: {str(err).splitlines()[0]}"
            ) from None
        except (KeyError, ValueError, TypeError) as err:
            raise DistillError(f"{str(path)!r} is not a whole judo dataset: {err}") from None
    if pairs is None or not pairs.num_pairs:
        raise DistillError(
            f"the datasets {[str(p) for p in paths]} hold no training pairs; collect some "
            "episodes first"
        )
    return pairs


def _env_args(path: Path, file: Any) -> dict[str, Any]:
    data = file.get("data")
    env_args = None if data is None else data.attrs.get("env_args")
    try:
        parsed = json.loads(env_args) if env_args is not None else None
    except ValueError:
        parsed = None
    if not isinstance(parsed, dict) or parsed.get("type") != "judo":
        raise DistillError(
            f"{str(path)!r} is not a dataset of python -m judo collect (no judo env_args)"
        )
    return parsed


def _read_file(path: Path, file: Any, kind: str, pairs: TrainingPairs | None) -> TrainingPairs:
    """Add the episodes of the open h5py `file` to `pairs` (a new TrainingPairs when None)."""
    from judo.core.configuration.controller_config import ControllerConfig
    from judo.core.configuration.registry import make_config, make_task
    from judo.recording.model_info import config_dict

    env_args = _env_args(path, file)
    task_name = env_args["task"]
    if pairs is not None and pairs.task != task_name:
        raise DistillError(
            f"{str(path)!r} holds task {task_name!r}, the other datasets {pairs.task!r}; give "
            "one task"
        )
    demos = sorted(file["data"], key=lambda name: int(name.removeprefix("demo_")))
    if not demos:
        raise DistillError(
            f"{str(path)!r} holds no episodes; run python -m judo collect into it first"
        )
    task = make_task(task_name)
    low_level = task.low_level()
    if low_level is not None:
        raise DistillError(
            f"distill cannot learn task {task_name!r}: its MPC plans "
            f"{low_level.command_size} commands for a "
            f"low-level policy that drives the {task.nu} actuators, while a distilled policy "
            "is served to the "
            "actuators; give datasets of a task without a low-level policy"
        )
    controller = {
        **config_dict(make_config(ControllerConfig, task_name, env_args.get("optimizer")))
    }
    controller.update(env_args.get("env_kwargs", {}).get("controller", {}))
    time_step = float(env_args.get("plant_timestep", task.sim_model.opt.timestep))
    if pairs is None:
        pairs = TrainingPairs(task_name, kind, action_size=task.command_size)
        pairs.observation_layout = observation_layout(task)
        if kind == "action":
            # acts at every step, as it was trained
            pairs.controller = {"control_freq": repr(1.0 / time_step)}
        else:
            pairs.controller = {
                key: str(controller[key]) for key in ("control_freq", "horizon", "spline_order")
            }
    for name in demos:
        demo = file["data"][name]
        observations, targets = _demo_pairs(path, name, demo, task, kind, time_step)
        if kind == "chunk":
            horizon = targets.shape[1] // task.command_size
            if pairs.episodes and horizon != pairs.horizon:
                raise DistillError(
                    f"{str(path)!r} plans {horizon} knots, the other datasets {pairs.horizon}"
                )
            pairs.horizon = horizon
        if len(observations):
            pairs.observations.append(observations)
            pairs.targets.append(targets)
            pairs.episodes.append(f"{path.name}:{name}")
    return pairs


def _demo_pairs(
    path: Path, name: str, demo: Any, task: Task, kind: str, time_step: float
) -> tuple[np.ndarray, ...]:
    """(n, O) observations and (n, H * A) targets of one demo group."""
    states = np.concatenate([demo["obs/qpos"][()], demo["obs/qvel"][()]], axis=1)
    mocap = demo["obs/mocap_pos"][()] if "obs/mocap_pos" in demo else None
    served = demo["actions"][()]
    labels = demo["mpc_actions"][()] if "mpc_actions" in demo else served
    observations = episode_observations(
        task, states, mocap, served, time_step, recorded_metadata(path, name, demo, task)
    )
    if kind == "action":
        keep = np.isfinite(labels[1:]).all(axis=1) & np.isfinite(observations[:-1]).all(axis=1)
        return observations[:-1][keep], labels[1:][keep]
    if "plan/knots" not in demo or "plan/times" not in demo:
        raise DistillError(
            f"{str(path)!r} {name} has no plan/knots, which --kind chunk learns; use --kind action"
        )
    knots, times = demo["plan/knots"][()], demo["plan/times"][()]
    rows = np.round(times / time_step).astype(int) - 1
    keep = (rows >= 0) & (rows < len(states)) & np.isfinite(knots).all(axis=(1, 2))
    return observations[rows[keep]], knots[keep].reshape(int(keep.sum()), -1)
