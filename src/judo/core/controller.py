"""The sampling-based MPC loop, written once: shift, sample, clamp, interpolate, roll out, score,
update, publish. Its settings (`ControllerConfig`, `check_configs`) live in
`judo.core.configuration.controller_config`."""

import dataclasses
from time import perf_counter
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.config import snapshot
from judo.core.configuration.controller_config import ControllerConfig, check_configs, rollout_steps
from judo.core.errors import NonFiniteRewardError
from judo.core.feedback import FeedbackGains
from judo.core.model import STATE_SPEC, trace_sensor_columns
from judo.core.optimizer import (
    Optimizer,
    PlanningStart,
    ranked_rewards,
    sampled_knots,
    updated_knots,
)
from judo.core.planner import CancelFlag, PlanServer, task_warm_start, warm_start_takes_state
from judo.core.planner_view import CycleSize, PlannerKind
from judo.core.policies.proposals import Proposer, check_proposal_policy, insert_proposals
from judo.core.policy import Policy
from judo.core.reading import checked_reading, mocap_vector, model_at
from judo.core.rollouts.backend import PlanningCancelled, RolloutBackend, RolloutLimits
from judo.core.rollouts.dynamics import task_rollout_backend
from judo.core.rollouts.low_level_rollout import check_low_level_backend, with_low_level
from judo.core.rollouts.parallel_reward import ParallelReward
from judo.core.rollouts.randomize import randomized_models
from judo.core.rollouts.risk import reduce_rewards
from judo.core.spline import CycleLayout, Spline, clip_ufunc
from judo.core.task import Task

__all__ = ["Controller"]


class Controller(PlanServer):
    """Plans with `optimizer` on `task` and serves the resulting control spline.

    Attributes:
        config, task, optimizer: the parts; their configs may be edited between cycles.
        backend: the RolloutBackend every rollout runs on, built from the constructor's `backend`
            name ("cpu": `RolloutPool`, threads; "warp": `WarpRollout`, MuJoCo Warp on a GPU) or
            given built (a `ProblemSlot`); `DynamicsRollout` for a task with its own dynamics
            (judo.core.rollouts.dynamics); under a low-level policy (`Task.low_level`), a
            `LowLevelRollout` whose plan is its commands (`command_size`).
        backend_name: that name (read-only).
        nominal_knots: (num_nodes, nu) knots of the current plan, or None before the first update
            (nu is `task.command_size` throughout: the actuators, or a low-level policy's commands).
        rewards: (num_rollouts,) rewards of the last iteration's rollouts (NaN mapped to -inf); with
            num_randomizations R > 1, each sequence's R rewards reduced by the config's risk
            measure.
        iterations_run: optimizer iterations the last cycle ran (0 before the first).
        models: the R models the last cycle rolled out under: the task's planning model, then the
            R - 1 copies its `randomize_model` hook perturbed (drawn from `task.rng`).
        traces: (1 + num_shown, T, num_trace_sensors, 3) positions of the "trace" framepos sensors
            along the nominal rollout (index 0) and the best `max_num_traces` rollouts.
        proposal_policy: the Policy whose candidates replace the last `config.policy_samples` of the
            optimizer's samples every iteration (judo.core.policies.proposals): the one given, else
            the task's `default_proposal_policy()`, or None.
        limits: the RolloutLimits that screen each iteration's rollouts before ranking ([safety],
            via the loop), or None.
    """

    def __init__(
        self,
        controller_config: ControllerConfig,
        task: Task,
        optimizer: Optimizer,
        num_workers: int | None = None,
        backend: str | RolloutBackend = "cpu",
        proposal_policy: Policy | None = None,
    ) -> None:
        check_configs(task, controller_config, optimizer.config)
        if proposal_policy is None:  # the task's own, where it ships one (else None)
            proposal_policy = task.default_proposal_policy()
        self.proposal_policy = proposal_policy  # checked by its Proposer
        self._proposer = Proposer(task, proposal_policy, controller_config.policy_samples)
        self.config, self.task, self.optimizer = controller_config, task, optimizer
        if isinstance(backend, str):
            check_low_level_backend(backend, task.low_level())
            # own dynamics or MuJoCo
            self.backend: RolloutBackend = task_rollout_backend(task, backend, num_workers)
        else:  # a backend built by the caller (a ProblemBatch's slot), owned from now on
            self.backend = backend
        self.backend = with_low_level(self.backend, task.low_level())  # the pool itself without one
        self._backend_name = backend if isinstance(backend, str) else backend.name
        self._score = ParallelReward(self.backend.reward_threads)  # one call unless asked
        self.nominal_knots: np.ndarray | None = None
        self.rewards, self.traces = np.zeros(0), np.zeros((0, 0, 0, 3))
        self.iterations_run = 0
        self._plan: Spline | None = None
        self._layout_key: tuple | None = None
        self._scratch = mujoco.MjData(task.model)
        self._initial_state = np.zeros(mujoco.mj_stateSize(task.model, STATE_SPEC))
        self._initial_mocap = np.zeros(7 * task.model.nmocap)
        self._trace_columns = trace_sensor_columns(task.model)
        self._ctrl_low, self._ctrl_high = task.command_range.T.copy()
        self._num_state = task.model.nq + task.model.nv
        self.models: list[mujoco.MjModel] = [task.model]
        self._cycles_since_draw = 0
        self._warm_start_takes_state = warm_start_takes_state(task)
        self._gains = FeedbackGains(task, self.backend.num_workers if backend == "cpu" else None)
        self.limits: RolloutLimits | None = None
        self._sized: tuple[tuple, CycleSize] | None = None  # the last cycle_size, by its key

    kind = PlannerKind.MPC
    config_kinds = ("controller", "optimizer", "task")

    @property
    def controller_fields(self) -> tuple[str, ...]:
        """Every ControllerConfig field, but policy_samples without a proposal policy (only 0 would
        be accepted)."""
        names = tuple(f.name for f in dataclasses.fields(self.config))
        if self.proposal_policy is not None:
            return names
        return tuple(n for n in names if n != "policy_samples")

    def configs(self) -> dict[str, Any]:
        """{"controller": ..., "optimizer": ..., "task": ...}: the configs it plans with now."""
        return dict(controller=self.config, optimizer=self.optimizer.config, task=self.task.config)

    def check_configs(self, configs: dict[Any, Any]) -> None:
        """ConfigError unless `configs` work together; PolicyError unless the proposal policy fits
        their samples."""
        check_configs(self.task, configs["controller"], configs["optimizer"])
        check_proposal_policy(self.proposal_policy, configs["controller"].policy_samples)

    def cycle_size(self, configs: dict[Any, Any]) -> CycleSize:
        """num_rollouts x num_randomizations x iterations (`iterations_per_cycle`) x T under
        `configs`, kept by key."""
        cfg, opt, dt, sized = configs["controller"], configs["optimizer"], self.task.dt, self._sized
        key = (cfg.horizon, cfg.max_opt_iters, cfg.iterations_per_second, cfg.control_freq)
        key = (*key, cfg.num_randomizations, opt.num_rollouts, dt)
        if sized is None or sized[0] != key:
            steps, iterations = rollout_steps(cfg.horizon, dt), cfg.iterations_per_cycle
            sized = self._sized = (
                key,
                CycleSize(opt.num_rollouts, cfg.num_randomizations, iterations, steps),
            )
        return sized[1]

    @property
    def num_steps(self) -> int:
        """Rollout length T in steps: the horizon divided by the timestep, rounded."""
        return rollout_steps(self.config.horizon, self.task.dt)

    def reset(self) -> None:
        """Forget the plan and restart the optimizer's search; the next update starts again from the
        task's warm start."""
        self._plan, self.nominal_knots = None, None
        self.optimizer.restart()

    def _apply_config_changes(self) -> None:
        """Rebuild the spline weights when horizon, order or sizes changed since the last cycle.

        Everything new is built first and assigned only once all of it succeeded, so a refused
        change leaves the previous layout (and its key) in force, and reverting the edit works.
        """
        opt, cfg = self.optimizer, self.config
        key = (cfg.horizon, cfg.spline_order, opt.config.num_rollouts, opt.config.num_nodes)
        # policy_samples: checked against num_rollouts
        key = (*key, self.task.dt, cfg.num_randomizations, cfg.policy_samples)
        if key == self._layout_key:
            return
        check_configs(self.task, cfg, opt.config)
        num_rollouts, num_nodes = opt.config.num_rollouts, opt.config.num_nodes
        num_steps = rollout_steps(cfg.horizon, self.task.dt)
        num_models = cfg.num_randomizations
        sizes = (num_models, num_rollouts, num_nodes, self.task.command_size)
        layout = CycleLayout.build(cfg.horizon, cfg.spline_order, self.task.dt, num_steps, sizes)
        if num_models != len(self.models):
            self._set_models(num_models)  # a hook that fails raises here, before the layout changes
        opt.num_rollouts, opt.num_nodes = num_rollouts, num_nodes
        self._layout, self._num_steps, self._layout_key = layout, num_steps, key

    def _set_models(self, num_models: int) -> None:
        """Draw `num_models` models (the planning model and perturbed copies) and give them to the
        backend."""
        task = self.task
        models = randomized_models(task, num_models, task.rng) if num_models > 1 else [task.model]
        self.backend.set_models(None if num_models == 1 else models)
        self.models = models
        self._cycles_since_draw = 0

    def update_action(
        self,
        state: np.ndarray,
        time: float,
        system_metadata: dict[str, Any] | None = None,
        cancel: CancelFlag | None = None,
        deadline: float | None = None,
    ) -> Spline:
        """Run one planning cycle from `state` (nq + nv,) at sim `time`, publish the new plan and
        return it.

        The cycle runs `config.iterations_per_cycle` optimizer iterations, each the phases
        `_sample`, `_clamp`, `_roll_out`, `_score_rollouts`, `_update`; `_publish` ends it. With a
        `deadline` (a time.perf_counter() value: the app gives each cycle its control period) the
        iterations beyond `config.max_opt_iters` run only while one more, as long as the last, ends
        before it; `iterations_run` says how many ran.

        A set `cancel` (a threading.Event, the app's stop or planning cycle) ends the cycle with
        PlanningCancelled, keeping the previous plan: before its next optimizer iteration, or
        between pieces of a batch of rollouts (the CPU pool). `action(t)` serves the returned plan
        from now on (a caller that models latency serves the previous one itself until it is due).

        Raises JudoError for a non-finite state or time, ConfigError if the configs were edited into
        an invalid combination, NonFiniteRewardError if every rollout scored NaN or -inf, and
        NonFiniteKnotsError if the optimizer produced NaN or infinite knots; in each case the
        previous plan stays in force."""
        nominal, task_config, candidates = self._begin(state, time, system_metadata)
        required, iteration_started = self.config.max_opt_iters, 0.0
        opt = self.optimizer
        size = self.cycle_size({"controller": self.config, "optimizer": opt.config})
        # the plan in force now (or the warm start): the rate limits' step before
        served = nominal[0].copy()
        # polled between pieces of a big batch too, and None again after the cycle
        self.backend.cancel = cancel
        try:
            for iteration in range(size.iterations):
                if cancel is not None and cancel.is_set():
                    raise PlanningCancelled(
                        "planning cycle cancelled; the previous plan stays in force"
                    )
                # an extra iteration starts only if one as long as the last fits
                if deadline is not None:
                    now = perf_counter()
                    if iteration >= required and 2 * now - iteration_started > deadline:
                        break
                    iteration_started = now
                self.iterations_run = iteration + 1
                knots = self._sample(nominal)
                self._clamp(knots, candidates)
                states, sensors = self._roll_out()
                rewards, sensors = self._score_rollouts(
                    states, sensors, served, task_config, system_metadata
                )
                nominal = self._update(knots, rewards)
                if opt.stop_cond():
                    break
        finally:
            self.backend.cancel = None
        return self._publish(time, nominal, rewards, sensors)

    def _begin(
        self, state: np.ndarray, time: float, system_metadata: dict[str, Any] | None
    ) -> tuple:
        """Check the reading, apply config edits, and set the optimizer's start: (nominal knots, the
        task config's snapshot, the proposal policy's candidates or None)."""
        state = checked_reading(state, time, self._num_state, "plan from")
        self._apply_config_changes()
        # the randomized models are redrawn every `redraw_every` cycles (never when it is 0)
        cfg = self.config
        redraw = cfg.redraw_every and self._cycles_since_draw >= cfg.redraw_every
        if cfg.num_randomizations > 1 and redraw:
            self._set_models(cfg.num_randomizations)
        self._cycles_since_draw += 1
        opt, task = self.optimizer, self.task
        knot_times = time + self._layout.knot_offsets
        if self._plan is None:
            warm = task_warm_start(task, state, self._warm_start_takes_state)
            nominal = np.tile(warm, (opt.num_nodes, 1)).astype(float)
            old_times = knot_times
        else:
            nominal = self._plan(knot_times)
            old_times = self._plan.knot_times
        opt.pre_optimization(old_times, knot_times)
        data = model_at(task.model, self._scratch, state, time, system_metadata, forward=False)
        mujoco.mj_getState(task.model, data, self._initial_state, STATE_SPEC)
        if len(self._initial_mocap):  # a model without mocap bodies has none to copy
            self._initial_mocap[:] = mocap_vector(data)
        task.pre_rollout(state)
        task_config, initial = snapshot(task.config), (self._initial_state, self._initial_mocap)
        weights = self._layout.rollout_weights
        opt.set_start(PlanningStart(task, *initial, weights, task_config, system_metadata))
        policy, count = self.proposal_policy, self.config.policy_samples
        # none to check or make
        if policy is None and not count and self._proposer.last_error is None:
            return nominal, task_config, None
        start = (*initial, self._layout.basis, self._num_steps, system_metadata)
        return nominal, task_config, self._proposer.candidates(policy, count, *start, nominal[0])

    def _sample(self, nominal: np.ndarray) -> np.ndarray:
        """The optimizer's (num_rollouts, num_nodes, nu) knots around `nominal`, checked."""
        return sampled_knots(self.optimizer, nominal, self.task.command_size)

    def _clamp(self, knots: np.ndarray, candidates: Any) -> None:
        """Put the proposals into `knots`, clamp them (in place) and interpolate them into the
        rollouts' controls."""
        rows = None if candidates is None else insert_proposals(knots, candidates)
        clip_ufunc(knots, self._ctrl_low, self._ctrl_high, out=knots)
        if rows is not None:
            self.optimizer.samples_replaced(rows, knots[rows])
        layout = self._layout
        np.matmul(layout.rollout_weights, knots, out=layout.controls)
        # Clamp what the rollouts apply exactly as `action(t)` clamps what the plant gets, so
        # the plan that is scored is the plan that is served (a cubic overshoots its knots).
        np.minimum(layout.controls, self._ctrl_high, out=layout.controls)
        np.maximum(layout.controls, self._ctrl_low, out=layout.controls)
        if len(self.models) > 1:
            layout.control_blocks[:] = layout.controls  # every sequence once per model

    def _roll_out(self) -> tuple[np.ndarray, np.ndarray]:
        """(R * N, T, nq + nv) states (time dropped) and (R * N, T, nsensordata) sensors of the
        batch's rollouts."""
        full_states, sensors = self.backend.rollout(
            self._initial_state, self._layout.batch_controls, self._initial_mocap
        )
        return full_states[..., 1 : 1 + self._num_state], sensors  # drop time; keep [qpos, qvel]

    def _score_rollouts(
        self,
        states: Any,
        sensors: Any,
        served: np.ndarray,
        task_config: Any,
        system_metadata: dict[str, Any] | None,
    ) -> tuple[np.ndarray, Any]:
        """(N,) rewards of the rollouts (NaN, +inf, diverged and over-limit: -inf; R models reduced
        by the risk measure), and the planning model's block of `sensors`; the task's `post_rollout`
        sees them."""
        opt, task, cfg, num_models = self.optimizer, self.task, self.config, len(self.models)
        # one plain call on one thread
        args = (states, sensors, self._layout.batch_controls, task_config, system_metadata)
        returned = (
            self._score(task.reward, *args) if self._score.num_threads > 1 else task.reward(*args)
        )
        rows = num_models * opt.num_rollouts
        rewards = ranked_rewards(returned, type(task).__name__, rows, self.backend.diverged)
        if self.limits is not None:  # a rollout that crosses a hard limit never wins either
            rewards = self.limits.screen(
                rewards, states, sensors, self._layout.batch_controls, served, num_models
            )
        # (R * N,) -> (N, R) -> (N,) by the risk measure; keep the planning model's block
        if num_models > 1:
            rewards = reduce_rewards(
                rewards.reshape(num_models, -1).T, cfg.risk, cfg.cvar_alpha, cfg.risk_scale
            )
            states, sensors = states[: opt.num_rollouts], sensors[: opt.num_rollouts]
        task.post_rollout(states, sensors, self._layout.controls, rewards)
        if not np.isfinite(rewards).any():
            raise NonFiniteRewardError(
                f"all {opt.num_rollouts} rollouts of {type(task).__name__} scored NaN or "
                "-inf; keeping the previous plan"
            )
        return rewards, sensors

    def _update(self, knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        """The optimizer's new nominal knots from the scored `knots`, checked."""
        return updated_knots(self.optimizer, knots, rewards)

    def _publish(
        self, time: float, nominal: np.ndarray, rewards: np.ndarray, sensors: Any
    ) -> Spline:
        """The clamped `nominal` as the plan from `time` (with gains under `config.feedback`); keeps
        rewards, traces."""
        cfg, self.rewards = self.config, rewards
        self.nominal_knots = nominal = clip_ufunc(nominal, self._ctrl_low, self._ctrl_high)
        self._plan = Spline(time, self._layout.basis, nominal, self._ctrl_low, self._ctrl_high)
        if cfg.feedback:  # with the gains around its nominal rollout (judo.core.feedback)
            start = (self._initial_state, self._initial_mocap)
            batch, period = self.optimizer.num_rollouts * len(self.models), 1.0 / cfg.control_freq
            weights = self._layout.rollout_weights
            self._plan = self._gains.add_to(self._plan, weights, *start, batch, period)
        shown = np.argsort(-rewards, kind="stable")[: cfg.max_num_traces]
        rows = self._layout.trace_rows[: len(shown) + 1]  # row 0 stays 0: the nominal
        rows[1:] = shown
        traces = sensors[rows][..., self._trace_columns]
        self.traces = traces.reshape(len(rows), self._num_steps, -1, 3)
        # what the loop records of the update
        self._plan.rewards, self._plan.traces = rewards, self.traces
        return self._plan

    @property
    def batch_controls(self) -> np.ndarray:
        """(R * num_rollouts, T, nu) the controls the last optimizer iteration rolled out (block r
        under model r), clamped as served; zeros before the first update. A view: copy it to keep
        it."""
        self._apply_config_changes()
        return self._layout.batch_controls

    @property
    def backend_name(self) -> str:
        """The name the rollout backend was built from, one of ROLLOUT_BACKENDS ("cpu", "warp")."""
        return self._backend_name

    def close(self) -> None:
        """Release the rollout backend's threads or device memory, and the reward's and the gains'
        threads."""
        self.backend.close()
        self._score.close()
        self._gains.close()
