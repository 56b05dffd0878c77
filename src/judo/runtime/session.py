"""What the app runs at one moment: a task and optimizer by name, their Controller, the plant, and
the closed loop between them.

Switching task or optimizer builds a new Session and closes the old one; nothing is patched in
place.

`SessionMaker` builds the app's sessions: the first one, and the one that replaces it on a switch.
The settings that stay for the whole run (the user's System, the seed, the rollout threads and
backend, the watchdog's clock and its reports) are given once; `first` and `switched` build a
`Session` with them.
"""

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import cast

from judo.core.configuration.config import Config
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import (
    CONFIG_KINDS,
    ConfigKind,
    default_configs,
    lookup_optimizer,
    lookup_task,
    make_config,
    make_controller,
)
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.planner_view import AppPlanner, PlannerKind
from judo.core.policies.policy_controller import make_policy_controller, policy_config
from judo.core.policy import Policy
from judo.core.reading import SystemState
from judo.core.task import TaskConfig
from judo.evaluation.sensing import Sensing, choose_estimator, observed_plant
from judo.loop.closed_loop import ClosedLoop
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem, System
from judo.runtime.running.estimator_thread import EstimatorThread
from judo.safety.config import SafetyConfig
from judo.safety.serve_filter import safety_guard
from judo.safety.stop import StopLatch

CONFIG_CLASSES: dict[str, type] = {
    "controller": ControllerConfig,
    "optimizer": OptimizerConfig,
    "task": TaskConfig,
}
"""The class of each kind of config."""
KEPT_UPDATES = 1000
"""Control updates whose times the app's loop keeps (the GUI reads the latest 100, the latency
estimate the latest 5): an app runs for days, and a list of every update's grew about 80 kB a minute
at 20 Hz."""


@dataclass(frozen=True)
class ConfigSet:
    """The configs of a session, one typed field per kind; `kinds` are those its planner
    has (its `config_kinds`: no "optimizer" where a policy drives the session, whose `optimizer` is
    then None)."""

    controller: ControllerConfig
    optimizer: OptimizerConfig | None
    task: TaskConfig
    kinds: tuple[ConfigKind, ...] = CONFIG_KINDS
    by_kind: dict[ConfigKind, Config] = field(init=False, repr=False, compare=False)
    """{kind: config} of the kinds the session has, made once (read it, never change it; `as_dict`
    gives a copy)."""

    def __post_init__(self) -> None:
        # frozen
        object.__setattr__(self, "by_kind", {kind: getattr(self, kind) for kind in self.kinds})

    @classmethod
    def of(cls, session: "Session") -> "ConfigSet":
        """The configs `session`'s controller uses (`PlannerView.configs`)."""
        return cls.from_dict(session.controller.configs())

    @classmethod
    def from_dict(cls, configs: dict[ConfigKind, Config]) -> "ConfigSet":
        """{kind: config} (e.g. `judo.core.configuration.registry.default_configs`; "controller" and
        "task" at least) as a ConfigSet; TypeError for a config of the wrong type."""
        for kind, config in configs.items():
            if not isinstance(config, CONFIG_CLASSES[kind]):
                raise TypeError(
                    f"the {kind} config must be a {CONFIG_CLASSES[kind].__name__}, got "
                    f"{type(config)}"
                )
        kinds: tuple[ConfigKind, ...] = tuple(kind for kind in CONFIG_KINDS if kind in configs)
        controller, optimizer = (
            cast(ControllerConfig, configs["controller"]),
            cast(OptimizerConfig | None, configs.get("optimizer")),
        )
        # the types checked above
        return cls(controller, optimizer, cast(TaskConfig, configs["task"]), kinds)

    def get(self, kind: ConfigKind) -> Config | None:
        """The config of `kind` (None: the session has none of that kind)."""
        return getattr(self, kind)

    def with_config(self, kind: ConfigKind, config: Config) -> "ConfigSet":
        """A copy with `config` as the `kind` config."""
        return replace(self, **{kind: config})

    def as_dict(self) -> dict[ConfigKind, Config]:
        """{kind: config} of the kinds the session has, for the GUI and recordings."""
        return dict(self.by_kind)


@dataclass
class Session:
    """A controller, its plant and the closed loop between them.

    Attributes:
        task_name, optimizer_name: registry names.
        controller: the Planner (a Controller, or a PolicyController where a policy drives), and the
            PlannerView the app and the GUI read (`judo.core.planner_view`); plans on its own Task
            instance (`controller.task`).
        system: the plant; a MujocoSystem simulating its own task instance (behind a SensedSystem
            when observing sensors), or the user's own System.
        closed_loop: the one closed-loop step on `controller` and `system`.
        estimator_name: the estimator the closed loop runs (`closed_loop.estimator`), or None when
            it plans from the System's full-state readings as they are.
        generation: counts sessions within one app, so stale GUI edits and snapshots are recognised.
    """

    task_name: str
    optimizer_name: str
    controller: AppPlanner
    system: System
    closed_loop: ClosedLoop
    generation: int
    estimator_name: str | None = None

    simulated: MujocoSystem | None = field(init=False, repr=False)
    """The plant when it is the app's own simulation (goals can be moved, configs shared), else
    None; the simulator itself when it is observed through a SensedSystem. Set once: the plant
    runner reads it on every tick."""

    def __post_init__(self) -> None:
        system = self.system.system if isinstance(self.system, SensedSystem) else self.system
        self.simulated = system if isinstance(system, MujocoSystem) else None

    def close(self) -> None:
        """Stop the controller's rollout threads, and the estimator's thread where it runs on
        one."""
        if isinstance(self.closed_loop.estimator, EstimatorThread):
            self.closed_loop.estimator.close()
        self.controller.close()


def build_session(
    task_name: str,
    optimizer_name: str,
    generation: int,
    *,
    controller_config: ControllerConfig | None = None,
    optimizer_config: OptimizerConfig | None = None,
    task_config: TaskConfig | None = None,
    system: System | None = None,
    seed: int | None = None,
    num_workers: int | None = None,
    backend: str = "cpu",
    clock: Callable[[], float] | None = None,
    on_watchdog: Callable[[str | None], None] | None = None,
    sensing: Sensing | None = None,
    reading: SystemState | None = None,
    estimator_thread: bool = False,
    proposal_policy: Policy | None = None,
    policy: Policy | None = None,
    stop: StopLatch | None = None,
) -> Session:
    """A new Session. Configs left out get the task's registered defaults.

    With no `system`, the plant is `MujocoSystem.from_task` of the controller's task (its config
    shared, seeded by `seed`, at its start state). A given `system` is kept as it is, e.g. the
    user's hardware or the running plant when only the optimizer changes. `backend` names the
    controller's rollout backend; `clock`, `on_watchdog` and `stop` go to the closed loop (its
    watchdog's clock, its trip/recovery callback, and the latched stop).

    `sensing` says how a new simulated plant is observed (observe="sensors" wraps it in a
    SensedSystem whose noise draws from [seed, SENSING_STREAM]) and which estimator the closed loop
    runs: the named one, else the task's `default_estimator` when the plant's first reading has no
    full state, else none (plan from the reading as it is). `reading` is the given `system`'s latest
    reading, when another thread is driving it (a switch); None reads it here. `proposal_policy`
    makes the controller's `policy_samples` candidates (judo.core.policies.proposals; PolicyError
    unless it fits the task). `policy` drives the plant instead of an optimizer (`optimizer_name` is
    then PlannerKind.POLICY.value and `optimizer_config` unused; `controller_config` None takes the
    policy's metadata's rate). `estimator_thread` runs the estimator on a thread of its own
    (`EstimatorThread`), for the app's plant thread, which must not wait for the filter; evaluate's
    sim-time episodes leave it off. Raises UnknownNameError for an unregistered name and ConfigError
    for configs that do not work together (e.g. observing sensors on a task that declares none, or
    an estimator that cannot fuse the plant's readings).
    """
    sensing = sensing if sensing is not None else Sensing()
    sensing.check()
    # the policy is the controller (judo.core.policies.policy_controller); the loop is the same
    if policy is not None:
        controller: AppPlanner = make_policy_controller(
            task_name, policy, controller_config=controller_config, seed=seed
        )
    else:
        controller = make_controller(
            task_name,
            optimizer_name,
            controller_config=controller_config,
            optimizer_config=optimizer_config,
            num_workers=num_workers,
            seed=seed,
            backend=backend,
            proposal_policy=proposal_policy,
        )
    if task_config is not None:
        controller.task.config = task_config
    try:
        if system is None:
            system = observed_plant(controller.task, seed, sensing)
        name, estimator = choose_estimator(controller.task, task_name, system, sensing, reading)
        if estimator is not None and estimator_thread:
            estimator = EstimatorThread(estimator)
        closed_loop = ClosedLoop(
            controller,
            system,
            clock=clock,
            on_watchdog=on_watchdog,
            estimator=estimator,
            keep_updates=KEPT_UPDATES,
            stop=stop,
            # [safety.TASK]: docs/safety.md
            guard=safety_guard(controller, make_config(SafetyConfig, task_name)),
        )
    except BaseException:
        controller.close()
        raise
    return Session(task_name, optimizer_name, controller, system, closed_loop, generation, name)


@dataclass(frozen=True, kw_only=True)
class SessionMaker:
    """Builds the app's sessions.

    Attributes:
        user_system: the user's plant (a robot), kept for the whole run; None simulates each task.
        seed: seeds the optimizer, the task and the simulated plant.
        num_workers: rollout threads (None: one per core).
        backend: the rollout backend's name.
        clock: the closed loop's watchdog clock: wall time for a user's System, None (plant time)
            for judo's own simulator, which waits for the planner instead.
        on_watchdog: the closed loop's trip / recovery callback.
        proposal_policy: makes the `policy_samples` candidates of every session of `proposal_task`,
            the task it was made for (a session of another task plans without it).
        proposal_task: the task `proposal_policy` is for.
        policy: the policy that drives the plant in sessions whose optimizer choice is
            PlannerKind.POLICY.value, the GUI's "policy" (of `policy_task`).
        policy_task: the task `policy` is for.
        fallback_optimizer: the optimizer of a session of another task than `policy_task` switched
            to from the policy's.
        stop: the app's latched stop, given to every session's closed loop (a switch keeps it).
    """

    user_system: System | None
    seed: int | None
    num_workers: int | None
    backend: str
    clock: Callable[[], float] | None
    on_watchdog: Callable[[str | None], None]
    proposal_policy: Policy | None = None
    proposal_task: str | None = None
    policy: Policy | None = None
    policy_task: str | None = None
    fallback_optimizer: str = "mppi"
    stop: StopLatch | None = None

    def default_configs(self, task: str, optimizer: str) -> ConfigSet:
        """The registered defaults of a session of `task` with `optimizer`; for the policy's, the
        controller's as the policy's metadata sets them, and no optimizer config."""
        policy = self.driver(task, optimizer)
        if policy is None:
            return ConfigSet.from_dict(default_configs(task, optimizer))
        controller = policy_config(policy, make_config(ControllerConfig, task))
        return ConfigSet.from_dict(
            {"controller": controller, "task": make_config(lookup_task(task)[1], task)}
        )

    def driver(self, task: str, optimizer: str) -> Policy | None:
        """The policy that drives a session of `task` whose optimizer choice is `optimizer`: the
        app's policy where the choice names it (PlannerKind.POLICY.value, the GUI's "policy"), None
        where a registered optimizer plans. JudoError where the choice names the policy but the app
        has none, or it is for another task."""
        if PlannerKind.of_choice(optimizer) is PlannerKind.MPC:
            return None
        self.check_policy_session(task)
        return self.policy

    def check_choice(self, task: str, optimizer: str) -> None:
        """UnknownNameError or JudoError unless `optimizer` can plan a session of `task`: a
        registered optimizer's name, or the policy's (`driver`)."""
        if self.driver(task, optimizer) is None:
            lookup_optimizer(optimizer)

    def check_policy_session(self, task: str) -> None:
        """JudoError unless the policy can drive a session of `task`."""
        if self.policy is None:
            raise JudoError(
                "no policy to switch to: start the app with one (App(policy=...), python -m "
                "judo --policy FILE.onnx)"
            )
        if task != self.policy_task:
            raise JudoError(
                f"the policy {self.policy.name!r} is for {self.policy_task!r}, not {task!r}"
            )

    def first(
        self,
        task: str,
        optimizer: str,
        sensing: Sensing,
        controller_config: ControllerConfig | None = None,
        optimizer_config: OptimizerConfig | None = None,
        task_config: TaskConfig | None = None,
    ) -> Session:
        """The app's first session (generation 0); configs left out get the task's registered
        defaults."""
        return self._build(
            task, optimizer, 0, sensing, controller_config, optimizer_config, task_config, None
        )

    def switched(
        self, old: Session, task: str, optimizer: str, sensing: Sensing, configs: ConfigSet
    ) -> Session:
        """The session that replaces `old` for `task` with `optimizer`.

        The same task keeps the running plant and the accepted `configs` of the controller and the
        task (and of the optimizer when only the estimator changes), and the running estimator's
        live config unless another estimator is asked for; another task starts from its registered
        defaults on a new plant (or the user's System)."""
        kind = PlannerKind.of_choice(optimizer)
        # the policy is its own task's only
        if kind is PlannerKind.POLICY and task != self.policy_task:
            optimizer, kind = self.fallback_optimizer, PlannerKind.MPC
        estimator_only = (task, optimizer) == (old.task_name, old.optimizer_name)
        if task != old.task_name:
            return self._build(task, optimizer, old.generation + 1, sensing, None, None, None, old)
        # the estimator's live config goes on with the running plant, unless replaced
        estimator = old.closed_loop.estimator
        if estimator is not None and sensing.estimator in (None, old.estimator_name):
            sensing = replace(sensing, estimator_config=estimator.config)
        optimizer_config = configs.optimizer if estimator_only else None
        same_kind = kind is old.controller.kind
        # a policy's rate is not an optimizer's
        controller_config = configs.controller if same_kind else None
        return self._build(
            task,
            optimizer,
            old.generation + 1,
            sensing,
            controller_config,
            optimizer_config,
            configs.task,
            old,
        )

    def _build(
        self,
        task: str,
        optimizer: str,
        generation: int,
        sensing: Sensing,
        controller_config: ControllerConfig | None,
        optimizer_config: OptimizerConfig | None,
        task_config: TaskConfig | None,
        old: Session | None,
    ) -> Session:
        system = old.system if old is not None and task == old.task_name else self.user_system
        return build_session(
            task,
            optimizer,
            generation,
            controller_config=controller_config,
            optimizer_config=optimizer_config,
            task_config=task_config,
            system=system,
            seed=self.seed,
            num_workers=self.num_workers,
            backend=self.backend,
            clock=self.clock,
            on_watchdog=self.on_watchdog,
            sensing=sensing,
            # being read
            reading=old.closed_loop.raw_reading
            if old is not None and system is old.system
            else None,
            # the plant thread only reads, steps and serves (judo.loop.estimator_thread)
            estimator_thread=True,
            proposal_policy=self.proposal_policy if task == self.proposal_task else None,
            policy=self.driver(task, optimizer),
            stop=self.stop,
        )
