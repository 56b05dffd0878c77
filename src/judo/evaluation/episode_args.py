"""`EpisodeArgs`: the arguments every command that runs seeded episodes shares (evaluate, collect).

The task and optimizer, the --config file, the episode's length and latency, the rollout backend,
the `--controller.FIELD` overrides (and the `--optimizer-config.FIELD` and `--task-config.FIELD`
groups that `parse_args_with_config_fields` adds), and from `SensingFlags` how the plant is observed
and estimated. `spec()` turns them into the `EpisodeSpec` of the one seeded episode runner.
"""

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import tyro

from judo.cli_shared import episode_latency
from judo.core.configuration.config import require, require_between
from judo.core.configuration.registry import lookup_task
from judo.core.estimator import estimator_in_force
from judo.core.rollouts.backend import RolloutBackendName
from judo.evaluation.seeded import EpisodeSpec
from judo.evaluation.sensing import SensingFlags
from judo.evaluation.shared_options import (
    ControllerOverrides,
    check_episode_args,
    given_fields,
    latency_label,
)
from judo.loop.timing import Latency


@dataclass
class EpisodeArgs(SensingFlags):
    """What determines a command's episodes, apart from their seeds."""

    task: Annotated[str, tyro.conf.arg(metavar="NAME")]
    """Task to run, by registered name."""
    optimizer: Annotated[
        str | None, tyro.conf.arg(metavar="NAME", help_behavior_hint="(optional with --policy)")
    ] = None
    """Optimizer to run, by registered name."""
    policy: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.onnx", help_behavior_hint="(optional)")
    ] = None
    """A policy (an ONNX file, run on onnxruntime) that drives the plant instead of the optimizer,
    through the same closed loop (docs/policies.md); its metadata's control_freq, horizon and
    spline_order are the defaults of --controller.*."""
    proposal_policy: Annotated[
        Path | None, tyro.conf.arg(metavar="FILE.onnx", help_behavior_hint="(optional)")
    ] = None
    """Policy whose candidates replace --controller.policy-samples of the optimizer's num_rollouts
    each update (the policy as a proposal, docs/policies.md). With collect --policy, the MPC that
    labels samples from it (gpc's augmented controller)."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file, as for the app, that registers custom tasks and optimizers and sets per-task
    overrides (docs/configuration.md); read before anything else."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant only, by element name (a plant unlike the planning
    model, to rehearse on), e.g. body_mass.pole=0.13 "geom_friction.cube=[0.9, 0.005, 0.0001]";
    after the --config file's [plant_overrides.TASK] (docs/sysid.md)."""
    duration: float = 20.0
    """Length of each episode in seconds of sim time."""
    latency: Literal["none", "measured"] = "none"
    """Planning latency: none, or each update's measured wall time (which varies from run to
    run)."""
    latency_ms: Annotated[
        float | None, tyro.conf.arg(metavar="MS", help_behavior_hint="(optional)")
    ] = None
    """Fixed planning latency in milliseconds of sim time (reproducible); instead of --latency."""
    backend: RolloutBackendName = "cpu"
    """Rollout backend: cpu (threads) or warp (MuJoCo Warp; needs pip install -e ".[warp]")."""
    episodes_per_batch: int = 1
    """Run this many seeds side by side (threads of one process), their rollouts one batch of the
    warp backend per planning cycle (P episodes x N rollouts per launch): a GPU rolls out 4 x 256
    worlds in little more time than
    256. Needs --backend warp; not with --policy or randomized models."""
    controller: ControllerOverrides = field(default_factory=ControllerOverrides)  # pyright: ignore[reportInvalidTypeForm]
    """Controller settings to change from the task's defaults, e.g. --controller.horizon 1.0."""
    strict: bool = False
    """Exit with status 1 when a control update failed in any episode (non-finite actions from a
    policy, or no finite reward from the optimizer, so the task's safe action was served) or the
    simulation diverged; without it such runs are reported and exit 0."""

    def check(self) -> None:
        """Raise a JudoError naming the argument that is wrong (names, duration, latency, backend,
        config fields, sensing flags, a policy that does not fit the task)."""
        check_episode_args(self)
        self.sensing()
        require_between("--episodes-per-batch", self.episodes_per_batch, 1, 1024)
        require(
            self.episodes_per_batch == 1 or (self.backend == "warp" and self.policy is None),
            f"--episodes-per-batch {self.episodes_per_batch} batches episodes' rollouts on "
            "one warp backend; "
            f"expected --backend warp (got {self.backend}) and no --policy",
        )
        # checked here; the episodes apply them from their spec (`with_spec_plant`)
        if self.plant_overrides:
            from judo.core.configuration.model_override_checks import check_model_overrides
            from judo.core.configuration.model_overrides import parse_override_entries
            from judo.core.task import new_task

            check_model_overrides(
                new_task(lookup_task(self.task)[0]).sim_model,
                parse_override_entries(self.plant_overrides),
            )
        if self.policy is not None:
            from judo.core.policies.policy_controller import make_policy_controller

            # PolicyError, one line, if it does not fit
            make_policy_controller(self.task, self.policy).close()

    @property
    def runs_mpc(self) -> bool:
        """Whether an optimizer plans: alone (it drives the plant), or as the expert that labels a
        policy's states."""
        return isinstance(self.optimizer, str)

    def policy_file(self) -> str | None:
        """The --policy file as an absolute path (Ray workers read it from another directory), or
        None."""
        return None if self.policy is None else str(self.policy.resolve())

    def controller_label(self) -> str:
        """What drives the plant, for titles: the optimizer's name, or "policy NAME"."""
        if self.policy is not None:
            return f"policy {self.policy.stem}"
        assert isinstance(self.optimizer, str), "check() asks for --optimizer or --policy"
        return self.optimizer

    def changed_fields(self) -> dict[str, Any]:
        """Every config field given on the command line, {"controller.horizon": 1.0,
        "optimizer.sigma": 0.3, ...}."""
        groups = {
            "controller": self.controller,
            "optimizer": getattr(self, "optimizer_config", None),
            "task": getattr(self, "task_config", None),
        }
        return {
            f"{kind}.{name}": value
            for kind, group in groups.items()
            if group is not None
            for name, value in given_fields(group).items()
        }

    def config_file(self) -> str | None:
        """The --config file as an absolute path (Ray workers read it from another directory), or
        None."""
        return None if self.config is None else str(self.config.resolve())

    def episode_latency(self) -> Latency:
        """The latency `run_episode` takes: seconds, or "measured"."""
        return episode_latency(self.latency, self.latency_ms)

    def latency_label(self) -> str:
        """How the latency reads in titles and JSON: "none", "measured" or "25 ms"."""
        return latency_label(self.latency, self.latency_ms)

    def spec(self, num_workers: int | None) -> EpisodeSpec:
        """What determines each seed's episode, for the one seeded episode runner, with
        `num_workers` rollout threads per episode (None: one per core)."""
        return EpisodeSpec(
            self.task,
            self.optimizer,
            self.duration,
            self.episode_latency(),
            self.changed_fields(),
            self.config_file(),
            self.backend,
            num_workers,
            self.sensing(),
            self.policy_file(),
            None if self.proposal_policy is None else str(self.proposal_policy.resolve()),
            self.plant_overrides,
        )

    def sensing_label(self) -> str:
        """How the observation reads in titles: "" for the full state, else e.g. ", sensors +
        ekf"."""
        if self.observe == "state" and self.estimator is None:
            return ""
        if self.observe == "sensors":
            return f", sensors + {self.estimator_in_force()}"
        return f", {self.estimator}"

    def estimator_in_force(self) -> str | None:
        """The estimator the episodes run: --estimator, else the task's default with --observe
        sensors, else None."""
        return estimator_in_force(self.observe, self.estimator, lookup_task(self.task)[0])

    def sensing_record(self) -> dict[str, Any]:
        """The sensing flags as JSON: observe, noise, delay (s), rate (Hz) and estimator."""
        sensing = self.sensing()
        return {
            "observe": sensing.observe,
            "noise": sensing.noise,
            "delay_s": sensing.delay,
            "rate_hz": sensing.rate,
            "estimator": self.estimator_in_force(),
        }
