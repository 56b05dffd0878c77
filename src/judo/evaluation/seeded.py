"""The one seeded episode runner of evaluate, tune and collect: seed `seed`'s controller and plant,
run.

`run_seeded_episode(spec, seed)` builds the controller (`make_controller(..., seed=seed)`) with the
configs in force and the plant (`MujocoSystem.from_task(controller.task, seed)`), and runs
`run_episode` on them. Everything that determines the episode is in an `EpisodeSpec` of plain
values, so the same call runs in this process (evaluate without --workers) or as a Ray task on
another machine (evaluate --workers, the episodes of a tune trial, collect), and gives the same
episode bit for bit wherever it runs.
"""

import traceback
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import mujoco

from judo.core.configuration.config import Config, require
from judo.core.configuration.config_values import controller_config_of, optimizer_config_of
from judo.core.configuration.registry import ConfigKind, make_config
from judo.core.controller import Controller
from judo.core.errors import JudoError
from judo.core.planner_view import AppPlanner
from judo.core.policy import Policy
from judo.core.rollouts.backend import RolloutBackend
from judo.core.task import Task
from judo.evaluation.episode import EpisodeOutcome, EpisodeResult, run_episode
from judo.evaluation.sensing import Sensing, choose_estimator, observed_plant
from judo.loop.records import Recorder
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem
from judo.loop.timing import Latency
from judo.safety.config import SafetyConfig

T = TypeVar("T")

if TYPE_CHECKING:
    from judo.core.configuration.controller_config import ControllerConfig
    from judo.core.policies.policy_controller import PolicyController
    from judo.core.rollouts.problem_batch import ProblemBackend

_LOADED_CONFIG_FILES: set[str] = set()
"""--config files already read in this process (a Ray worker runs many episodes)."""

RecorderFactory = Callable[[AppPlanner, MujocoSystem], Iterable[Recorder]]
"""Makes an episode's extra recorders once its planner (a Controller, or a PolicyController where a
policy drives) and plant exist (they size their buffers from them)."""

PolicyRecorderFactory = Callable[["PolicyController", MujocoSystem], Iterable[Recorder]]
"""A RecorderFactory of an episode where a policy drives, for recorders that read the
PolicyController itself (its expert, its inference times); every RecorderFactory is one."""


@dataclass(frozen=True)
class EpisodeSpec:
    """What determines a seeded episode, apart from its seed.

    Attributes:
        task, optimizer: registered names.
        duration: seconds of sim time.
        latency: seconds of sim time between a plan's reading and its taking effect, or "measured".
        values: config fields changed from the pair's
            defaults, {"controller.horizon": 1.0, "optimizer.sigma": ...}.
        config_file: the user's --config file (read once per process), or None.
        backend: rollout backend, "cpu" or "warp".
        num_workers: rollout threads (None: one per core; 1 where episodes run in parallel, so they
            do not fight for cores).
        sensing: how the plant is observed (--observe, --sensor-*) and the estimator between its
            readings and the plan (--estimator); the full state as it is by default.
        policy: an .onnx file (absolute path) that drives the plant instead of the optimizer; with
            an optimizer too, the MPC plans from every state the policy is served from, for
            labels (collect --policy).
        proposal_policy: an .onnx file whose policy makes the controller's `policy_samples`
            candidates
            (judo.core.policies.proposals), or None.
    """

    task: str
    optimizer: str | None
    duration: float
    latency: Latency = 0.0
    values: dict[str, Any] = field(default_factory=dict)
    config_file: str | None = None
    backend: str = "cpu"
    num_workers: int | None = 1
    sensing: Sensing = field(default_factory=Sensing)
    policy: str | None = None
    proposal_policy: str | None = None
    plant_overrides: tuple[str, ...] = ()
    """--plant-overrides entries, FIELD.ELEMENT=VALUE: the simulated plant's model fields."""

    @property
    def runs_mpc(self) -> bool:
        """Whether an optimizer plans: alone (it drives the plant), or as the expert that labels a
        policy's states."""
        return isinstance(self.optimizer, str)

    def optimizer_name(self) -> str:
        """The optimizer that plans; JudoError where the spec names none (a policy alone, or
        nothing)."""
        if isinstance(self.optimizer, str):
            return self.optimizer
        raise JudoError(
            f"an episode of {self.task!r} needs an optimizer or a policy; the spec names neither"
        )


def load_config_once(path: str | None) -> None:
    """Read the user's --config file in this process, once (registering its classes and
    overrides)."""
    if path is None or path in _LOADED_CONFIG_FILES:
        return
    from judo.core.configuration.config_file import load_config

    load_config(path)
    _LOADED_CONFIG_FILES.add(path)


def configs_in_force(spec: EpisodeSpec) -> dict[ConfigKind, Config]:
    """{"controller", "optimizer", "task"}: the pair's registered configs with `spec.values`
    applied; reads `spec.config_file` first. ConfigError (or SearchSpaceError for an unknown field)
    if they do not fit."""
    from judo.core.configuration.config_values import apply_values
    from judo.core.configuration.registry import default_configs

    load_config_once(spec.config_file)
    if not spec.runs_mpc:  # a policy alone: no optimizer's config
        from judo.core.configuration.controller_config import ControllerConfig
        from judo.core.configuration.registry import lookup_task, make_config

        configs: dict[ConfigKind, Config] = {
            "controller": make_config(ControllerConfig, spec.task),
            "task": make_config(lookup_task(spec.task)[1], spec.task),
        }
        return apply_values(configs, spec.values)
    return apply_values(default_configs(spec.task, spec.optimizer_name()), spec.values)


def policy_config_in_force(spec: EpisodeSpec, policy: "Policy") -> "ControllerConfig":
    """The policy's ControllerConfig: the task's (and optimizer's) defaults, then the fields the
    policy's metadata sets, then the --controller.* fields given in `spec.values`, which win."""
    from judo.core.configuration.config_values import apply_values
    from judo.core.configuration.controller_config import ControllerConfig
    from judo.core.configuration.registry import make_config
    from judo.core.policies.policy_controller import policy_config

    base = policy_config(policy, make_config(ControllerConfig, spec.task, spec.optimizer))
    given = {name: value for name, value in spec.values.items() if name.startswith("controller.")}
    configs: dict[ConfigKind, Config] = {"controller": base}
    return controller_config_of(apply_values(configs, given))


def run_seeded_episode(
    spec: EpisodeSpec,
    seed: int,
    recorders: RecorderFactory | None = None,
    on_update: Callable[[float], None] | None = None,
    backend: RolloutBackend | None = None,
) -> EpisodeResult:
    """Run seed `seed`'s episode of `spec`; raises what the task, optimizer or configs raise.

    With `spec.sensing.observe` "sensors" the plant serves only the task's measured sensors (noise
    seeded by [seed, SENSING_STREAM]) through the estimator; the log, the metrics and the recorders'
    `state` hold the plant's true state either way.

    Args:
        spec: the task, optimizer, configs, duration, latency, backend and rollout threads.
        seed: seeds the controller's generators and the plant's (`MujocoSystem.from_task`).
        recorders: called with the controller and the plant before the episode; its recorders get
            every plan and step (e.g. collect's dataset recorder).
        on_update: called after each control update with the plant time (a progress bar).
        backend: the controller's rollout backend, owned by the episode from now on (a
            ProblemBatch's slot); built from `spec.backend` when None.
    """
    configs = configs_in_force(spec)
    if spec.policy is not None:
        return run_policy_episode(spec, seed, configs, recorders, on_update)
    spec.optimizer_name()  # JudoError where the spec names neither an optimizer nor a policy
    proposals = load_proposal_policy(
        spec.proposal_policy, controller_config_of(configs).policy_samples
    )
    with spec_controller(spec, configs, seed, backend, proposal_policy=proposals) as controller:
        controller.task.config = configs["task"]
        system = observed_plant(with_spec_plant(controller.task, spec), seed, spec.sensing)
        _, estimator = choose_estimator(controller.task, spec.task, system, spec.sensing)
        extra = list(recorders(controller, plant_of(system))) if recorders is not None else []
        # [safety.TASK] of the task's and the --config file
        safety = make_config(SafetyConfig, spec.task)
        return run_episode(
            controller,
            system,
            spec.duration,
            spec.latency,
            seed,
            on_update,
            extra,
            estimator,
            safety,
        )


def spec_controller(
    spec: EpisodeSpec,
    configs: Mapping[ConfigKind, Config],
    seed: int,
    backend: RolloutBackend | None = None,
    **extra: Any,
) -> Controller:
    """The Controller of `spec`'s task and optimizer with `configs` (of `configs_in_force`) in
    force, seeded by `seed`, rolling out on `backend` (built from `spec.backend` when None); its
    callers call it only for a spec that names an optimizer."""
    from judo.core.configuration.registry import make_controller

    return make_controller(
        spec.task,
        spec.optimizer_name(),
        controller_config=controller_config_of(configs),
        optimizer_config=optimizer_config_of(configs),
        num_workers=spec.num_workers,
        seed=seed,
        backend=spec.backend if backend is None else backend,
        **extra,
    )


def load_proposal_policy(path: str | None, policy_samples: int) -> Policy | None:
    """The OnnxPolicy in the file at `path` (None for None); ConfigError when there is a file but
    `policy_samples` in force is 0, so that it would never be used."""
    if path is None:
        return None
    require(
        policy_samples > 0,
        f"--proposal-policy {path} is given but policy_samples is 0, so it would never be "
        "used; set "
        "--controller.policy-samples K (1 to num_rollouts - 1)",
    )
    # onnxruntime only when a policy is asked for
    from judo.core.policies.onnx_policy import OnnxPolicy

    return OnnxPolicy(path)


def run_policy_episode(
    spec: EpisodeSpec,
    seed: int,
    configs: dict[ConfigKind, Config],
    recorders: PolicyRecorderFactory | None = None,
    on_update: Callable[[float], None] | None = None,
) -> EpisodeResult:
    """`run_seeded_episode` of a spec with a policy: a PolicyController drives the plant (with the
    optimizer, if the spec names one, as its expert labelling every state the policy is served from,
    sampling `policy_samples` of its candidates from `spec.proposal_policy` where one is given)."""
    from judo.core.policies.policy_controller import as_policy, make_policy_controller

    assert spec.policy is not None, "run_policy_episode runs a spec with a policy"
    policy = as_policy(spec.policy)
    expert = None
    if spec.runs_mpc:  # the MPC that labels; with a proposal policy, gpc's augmented controller
        proposals = load_proposal_policy(
            spec.proposal_policy, controller_config_of(configs).policy_samples
        )
        expert = spec_controller(spec, configs, seed, proposal_policy=proposals)
    config = policy_config_in_force(spec, policy)
    controller = make_policy_controller(
        spec.task, policy, controller_config=config, expert=expert, seed=seed
    )
    task = controller.task
    with controller:
        task.config = configs["task"]
        system = observed_plant(with_spec_plant(task, spec), seed, spec.sensing)
        _, estimator = choose_estimator(task, spec.task, system, spec.sensing)
        extra = list(recorders(controller, plant_of(system))) if recorders is not None else []
        # [safety.TASK] of the task's and the --config file
        safety = make_config(SafetyConfig, spec.task)
        return run_episode(
            controller,
            system,
            spec.duration,
            spec.latency,
            seed,
            on_update,
            extra,
            estimator,
            safety,
        )


def with_spec_plant(task: Task, spec: EpisodeSpec) -> Task:
    """`task` with `spec.plant_overrides` (--plant-overrides) added to the plant overrides that
    every plant built from it gets (`MujocoSystem.from_task`); its own models are left as they
    are."""
    if spec.plant_overrides:
        from judo.core.configuration.model_override_checks import check_model_overrides
        from judo.core.configuration.model_overrides import parse_override_entries

        merged = {field: dict(values) for field, values in task.plant_overrides.items()}
        for field, values in check_model_overrides(
            task.sim_model, parse_override_entries(spec.plant_overrides)
        ).items():
            merged.setdefault(field, {}).update(values)
        task.plant_overrides = merged
    return task


def plant_of(system: MujocoSystem | SensedSystem) -> MujocoSystem:
    """The simulator itself, also when it is observed through a SensedSystem."""
    return system.system if isinstance(system, SensedSystem) else system


def failure_reason(err: BaseException) -> str:
    """An exception as the one-line reason an episode failed: its type and message, and where for an
    exception that is not judo's own (e.g. "ZeroDivisionError: ... (my_task.py:12)")."""
    if isinstance(err, JudoError):
        return f"{type(err).__name__}: {err}"
    where = traceback.extract_tb(err.__traceback__)[-1]
    return f"{type(err).__name__}: {err} ({Path(where.filename).name}:{where.lineno})"


def planning_model(spec: EpisodeSpec) -> mujoco.MjModel:
    """The planning model of `spec`'s task as its episodes' controllers build it: after the --config
    file (custom tasks, [model_overrides]), for a backend that several episodes share."""
    from judo.core.configuration.registry import make_task

    load_config_once(spec.config_file)
    return make_task(spec.task).model


def run_side_by_side(
    backend: "ProblemBackend", seeds: list[int], run: Callable[[int, RolloutBackend], T]
) -> list[T]:
    """`run(seed, slot)` for every seed at once, on threads, each seed's controller rolling out on
    `slot`, its share of a ProblemBatch of `backend`: every planning cycle of the group is one
    launch of P x N rollouts (evaluate and collect --episodes-per-batch). A slot is closed when its
    run returns or raises, so the others never wait for an episode that ended. Returns the runs'
    results in the order of `seeds`; raises the first run's error after all of them ended."""
    from judo.core.rollouts.problem_batch import ProblemBatch

    batch = ProblemBatch(backend, len(seeds))

    def one(i: int) -> T:
        try:
            return run(seeds[i], batch.slots[i])
        finally:
            batch.slots[i].close()

    with ThreadPoolExecutor(len(seeds), thread_name_prefix="judo-episode") as threads:
        futures = [threads.submit(one, i) for i in range(len(seeds))]
        return [future.result() for future in futures]


def evaluate_seed(spec: EpisodeSpec, seed: int) -> EpisodeOutcome[EpisodeResult]:
    """`run_seeded_episode(spec, seed)` as a Ray task of evaluate: the EpisodeResult as the
    outcome's episode (evaluate reports failed updates and divergences, and fails none for them);
    never raises, a failure comes back with its reason."""
    try:
        result = run_seeded_episode(spec, seed)
    except Exception as err:  # a user's task may raise anything; the other seeds go on
        return EpisodeOutcome.failed(seed, failure_reason(err))
    return EpisodeOutcome.of(result, result, None)
