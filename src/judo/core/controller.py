"""The sampling-based MPC loop, written once: shift, sample, clamp, interpolate, roll out, score, update."""

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.config import Config, require, snapshot
from judo.core.errors import ConfigError, JudoError
from judo.core.fields import slider
from judo.core.model import STATE_SPEC, trace_sensor_columns
from judo.core.optimizer import Optimizer, OptimizerConfig
from judo.core.rollout import make_rollout_backend
from judo.core.spline import MIN_KNOTS, Spline, SplineBasis, SplineOrder
from judo.core.task import Task


class NonFiniteRewardError(JudoError):
    """Every rollout of a cycle scored NaN or -inf, so there is nothing to learn from; the plan is kept."""


@slider("horizon", 0.05, 5.0, 0.05, log=False)  # seconds: read linearly
@slider("control_freq", 1.0, 200.0, 1.0)
@slider("max_opt_iters", 1, 20, 1)
@slider("max_num_traces", 0, 32, 1)
@dataclass
class ControllerConfig(Config):
    """Settings of the planning loop, shared by every task and optimizer."""

    horizon: float = 1.0
    """Planning horizon in seconds."""
    spline_order: SplineOrder = "linear"
    """How controls are interpolated between knots: zero-order hold, linear, or cubic (needs 4+ knots)."""
    control_freq: float = 20.0
    """Planning cycles per second that the app aims for."""
    max_opt_iters: int = 1
    """Optimizer iterations per planning cycle."""
    max_num_traces: int = 5
    """Best rollouts drawn as traces, besides the nominal."""

    def validate(self) -> None:
        super().validate()
        require(self.horizon > 0, f"horizon must be positive, got {self.horizon}")
        require(self.control_freq > 0, f"control_freq must be positive, got {self.control_freq}")
        require(self.max_opt_iters >= 1, f"max_opt_iters must be at least 1, got {self.max_opt_iters}")
        require(self.max_num_traces >= 0, f"max_num_traces must be at least 0, got {self.max_num_traces}")


def check_configs(task: Task, controller_config: ControllerConfig, optimizer_config: OptimizerConfig) -> None:
    """Raise ConfigError unless the configs work together on `task` (each is validated too)."""
    controller_config.validate()
    optimizer_config.validate()
    require(
        controller_config.horizon >= task.dt,
        f"horizon ({controller_config.horizon} s) is shorter than one timestep ({task.dt} s)",
    )
    order, nodes = controller_config.spline_order, optimizer_config.num_nodes
    require(nodes >= MIN_KNOTS[order], f"a {order} spline needs num_nodes >= {MIN_KNOTS[order]}, got {nodes}")


class Controller:
    """Plans with `optimizer` on `task` and serves the resulting control spline.

    Attributes:
        config, task, optimizer: the parts; their configs may be edited between cycles.
        backend: the RolloutBackend every rollout runs on ("cpu": `RolloutPool`, a thread pool).
        nominal_knots: (num_nodes, nu) knots of the current plan, or None before the first update.
        rewards: (num_rollouts,) rewards of the last iteration's rollouts (NaN mapped to -inf).
        traces: (1 + num_shown, T, num_trace_sensors, 3) positions of the "trace" framepos sensors
            along the nominal rollout (index 0) and the best `max_num_traces` rollouts.
    """

    def __init__(
        self,
        controller_config: ControllerConfig,
        task: Task,
        optimizer: Optimizer,
        num_workers: int | None = None,
        backend: str = "cpu",
    ) -> None:
        check_configs(task, controller_config, optimizer.config)
        self.config = controller_config
        self.task = task
        self.optimizer = optimizer
        self.backend = make_rollout_backend(backend, task.model, num_workers)
        self.nominal_knots: np.ndarray | None = None
        self.rewards = np.zeros(0)
        self.traces = np.zeros((0, 0, 0, 3))
        self._plan: Spline | None = None
        self._layout_key: tuple | None = None
        self._scratch = mujoco.MjData(task.model)
        self._initial_state = np.zeros(mujoco.mj_stateSize(task.model, STATE_SPEC))
        self._initial_mocap = np.zeros(7 * task.model.nmocap)
        self._trace_columns = trace_sensor_columns(task.model)
        self._ctrl_low, self._ctrl_high = task.actuator_ctrlrange.T.copy()
        self._num_state = task.model.nq + task.model.nv

    @property
    def num_steps(self) -> int:
        """Rollout length T in steps: the horizon divided by the timestep, rounded."""
        return max(1, round(self.config.horizon / self.task.dt))

    def reset(self) -> None:
        """Forget the plan and restart the optimizer's search; the next update starts again from the
        task's warm start."""
        self._plan = None
        self.optimizer.restart()
        self.nominal_knots = None

    def _apply_config_changes(self) -> None:
        """Rebuild the spline weights when horizon, order or sizes changed since the last cycle."""
        opt, cfg = self.optimizer, self.config
        key = (cfg.horizon, cfg.spline_order, opt.config.num_rollouts, opt.config.num_nodes, self.task.dt)
        if key == self._layout_key:
            return
        check_configs(self.task, cfg, opt.config)
        opt.num_rollouts, opt.num_nodes = opt.config.num_rollouts, opt.config.num_nodes
        self._knot_offsets = np.linspace(0.0, cfg.horizon, opt.num_nodes)
        self._basis = SplineBasis(self._knot_offsets, cfg.spline_order)
        self._rollout_weights = self._basis.weights(np.arange(self.num_steps) * self.task.dt)
        self._controls = np.zeros((opt.num_rollouts, self.num_steps, self.task.nu))
        self._layout_key = key

    def _set_initial_state(self, state: np.ndarray, time: float, system_metadata: dict[str, Any] | None) -> None:
        data = self._scratch
        data.time = time
        data.qpos[:] = state[: self.task.model.nq]
        data.qvel[:] = state[self.task.model.nq : self._num_state]
        if system_metadata:
            for key in ("mocap_pos", "mocap_quat"):
                if key in system_metadata:
                    getattr(data, key)[:] = system_metadata[key]
        mujoco.mj_getState(self.task.model, data, self._initial_state, STATE_SPEC)
        self._initial_mocap[:] = np.concatenate([data.mocap_pos.ravel(), data.mocap_quat.ravel()])

    def update_action(self, state: np.ndarray, time: float, system_metadata: dict[str, Any] | None = None) -> Spline:
        """Run one planning cycle from `state` (nq + nv,) at sim `time`, publish the new plan and return it.

        `action(t)` serves the returned plan from now on; a caller that models latency (the new plan
        taking effect only later) keeps the previous returned plan and evaluates it itself.

        Raises ConfigError if the configs were edited into an invalid combination, and
        NonFiniteRewardError if every rollout scored NaN or -inf; in both cases the previous plan
        stays in force.
        """
        state = np.asarray(state, dtype=float)
        if state.shape != (self._num_state,):
            raise ConfigError(f"state must have shape ({self._num_state},) = (nq + nv,), got {state.shape}")
        self._apply_config_changes()
        opt, task = self.optimizer, self.task
        knot_times = time + self._knot_offsets
        if self._plan is None:
            nominal = np.tile(task.optimizer_warm_start(), (opt.num_nodes, 1)).astype(float)
            old_times = knot_times
        else:
            nominal = self._plan(knot_times)
            old_times = self._plan.knot_times
        opt.pre_optimization(old_times, knot_times)
        self._set_initial_state(state, time, system_metadata)
        task.pre_rollout(state)
        task_config = snapshot(task.config)
        expected = (opt.num_rollouts, opt.num_nodes, task.nu)

        for _ in range(self.config.max_opt_iters):
            knots = opt.sample_control_knots(nominal)
            if knots.shape != expected:
                raise JudoError(
                    f"{type(opt).__name__}.sample_control_knots returned shape {knots.shape}, expected {expected}"
                )
            np.clip(knots, self._ctrl_low, self._ctrl_high, out=knots)
            np.matmul(self._rollout_weights, knots, out=self._controls)
            full_states, sensors = self.backend.rollout(self._initial_state, self._controls, self._initial_mocap)
            states = full_states[..., 1 : 1 + self._num_state]  # drop time; keep [qpos, qvel]
            rewards = np.asarray(
                task.reward(states, sensors, self._controls, task_config, system_metadata), dtype=float
            )
            if rewards.shape != (opt.num_rollouts,):
                raise JudoError(
                    f"{type(task).__name__}.reward returned shape {rewards.shape}, expected ({opt.num_rollouts},)"
                )
            rewards[np.isnan(rewards)] = -np.inf
            task.post_rollout(states, sensors, self._controls, rewards)
            if not np.isfinite(rewards).any():
                raise NonFiniteRewardError(
                    f"all {opt.num_rollouts} rollouts of {type(task).__name__} scored NaN or -inf; keeping the previous plan"
                )
            nominal = opt.update_nominal_knots(knots, rewards)
            if opt.stop_cond():
                break

        self.rewards = rewards
        self.nominal_knots = np.clip(nominal, self._ctrl_low, self._ctrl_high)
        self._plan = Spline(time, self._basis, self.nominal_knots)
        shown = np.argsort(-rewards, kind="stable")[: self.config.max_num_traces]
        self.traces = sensors[np.r_[0, shown]][..., self._trace_columns].reshape(len(shown) + 1, self.num_steps, -1, 3)
        return self._plan

    def action(self, time: float) -> np.ndarray:
        """(nu,) control of the current plan at sim `time` (held constant past its ends)."""
        if self._plan is None:
            return np.clip(self.task.optimizer_warm_start(), self._ctrl_low, self._ctrl_high)
        return self._plan(time)

    def close(self) -> None:
        """Release the rollout backend's threads or device memory."""
        self.backend.close()
