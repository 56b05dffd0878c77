"""How the app builds its sessions: the first one, and the one that replaces it on a switch.

The settings that stay for the whole run (the user's System, the seed, the rollout threads and backend, the
watchdog's clock and its reports) are given once; `first` and `switched` build a `Session` with them.
"""

from collections.abc import Callable
from dataclasses import dataclass, replace

from judo.core.controller import ControllerConfig
from judo.core.errors import JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.policy import Policy
from judo.core.policy_controller import policy_config
from judo.core.registry import default_configs, lookup_task, make_config
from judo.core.task import TaskConfig
from judo.loop.sensing import Sensing
from judo.loop.system import System
from judo.runtime.app_state import ConfigSet
from judo.runtime.session import POLICY_OPTIMIZER, Session, build_session


@dataclass(frozen=True)
class SessionMaker:
    """Builds the app's sessions.

    Attributes:
        user_system: the user's plant (a robot), kept for the whole run; None simulates each task.
        seed: seeds the optimizer, the task and the simulated plant.
        num_workers: rollout threads (None: one per core).
        backend: the rollout backend's name.
        clock: the closed loop's watchdog clock: wall time for a user's System, None (plant time) for judo's
            own simulator, which waits for the planner instead.
        on_watchdog: the closed loop's trip / recovery callback.
        proposal_policy: makes the `policy_samples` candidates of every session of `proposal_task`, the task it
            was made for (a session of another task plans without it).
        proposal_task: the task `proposal_policy` is for.
        policy: the policy that drives the plant in sessions whose optimizer is POLICY_OPTIMIZER (of `policy_task`).
        policy_task: the task `policy` is for.
        fallback_optimizer: the optimizer of a session of another task than `policy_task` switched to from the
            policy's.
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

    def default_configs(self, task: str, optimizer: str) -> ConfigSet:
        """The registered defaults of a session of `task` with `optimizer`; for the policy's, the controller's as the
        policy's metadata sets them, and no optimizer config."""
        if optimizer != POLICY_OPTIMIZER or self.policy is None:
            return ConfigSet.from_dict(default_configs(task, optimizer))
        controller = policy_config(self.policy, make_config(ControllerConfig, task))
        return ConfigSet(controller, None, make_config(lookup_task(task)[1], task))

    def check_policy_session(self, task: str) -> None:
        """JudoError unless the policy can drive a session of `task`."""
        if self.policy is None:
            raise JudoError(
                "no policy to switch to: start the app with one (App(policy=...), python -m judo --policy FILE.onnx)"
            )
        if task != self.policy_task:
            raise JudoError(f"the policy {self.policy.name!r} is for {self.policy_task!r}, not {task!r}")

    def first(
        self,
        task: str,
        optimizer: str,
        sensing: Sensing,
        controller_config: ControllerConfig | None = None,
        optimizer_config: OptimizerConfig | None = None,
        task_config: TaskConfig | None = None,
    ) -> Session:
        """The app's first session (generation 0); configs left out get the task's registered defaults."""
        if optimizer == POLICY_OPTIMIZER:
            self.check_policy_session(task)
        return self._build(task, optimizer, 0, sensing, controller_config, optimizer_config, task_config, None)

    def switched(self, old: Session, task: str, optimizer: str, sensing: Sensing, configs: ConfigSet) -> Session:
        """The session that replaces `old` for `task` with `optimizer`.

        The same task keeps the running plant and the accepted `configs` of the controller and the task (and of
        the optimizer when only the estimator changes), and the running estimator's live config unless another
        estimator is asked for; another task starts from its registered defaults on a new plant (or the
        user's System)."""
        if optimizer == POLICY_OPTIMIZER and task != self.policy_task:  # the policy is its own task's only
            optimizer = self.fallback_optimizer
        estimator_only = (task, optimizer) == (old.task_name, old.optimizer_name)
        if task != old.task_name:
            return self._build(task, optimizer, old.generation + 1, sensing, None, None, None, old)
        estimator = old.closed_loop.estimator  # its live config goes on with the running plant, unless replaced
        if estimator is not None and sensing.estimator in (None, old.estimator_name):
            sensing = replace(sensing, estimator_config=estimator.config)
        optimizer_config = configs.optimizer if estimator_only else None
        same_kind = (optimizer == POLICY_OPTIMIZER) == (old.optimizer_name == POLICY_OPTIMIZER)
        controller_config = configs.controller if same_kind else None  # a policy's rate is not an optimizer's
        return self._build(
            task, optimizer, old.generation + 1, sensing, controller_config, optimizer_config, configs.task, old
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
            reading=old.closed_loop.raw_reading if old is not None and system is old.system else None,  # being read
            estimator_thread=True,  # the plant thread only reads, steps and serves (judo.loop.estimator_thread)
            proposal_policy=self.proposal_policy if task == self.proposal_task else None,
            policy=self.policy if optimizer == POLICY_OPTIMIZER else None,
        )
