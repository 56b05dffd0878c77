"""The planning loop's settings (`ControllerConfig`), their bounds, and the check that configs work
together."""

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.configuration.config import Config, require, require_between
from judo.core.configuration.fields import slider
from judo.core.model import STATE_SPEC
from judo.core.optimizer import MAX_NUM_ROLLOUTS, OptimizerConfig
from judo.core.rollouts.risk import RiskMeasure
from judo.core.spline import MIN_KNOTS, SplineOrder
from judo.core.task import Task

MAX_HORIZON = 60.0
"""Longest planning horizon in seconds."""
MIN_CONTROL_FREQ, MAX_CONTROL_FREQ = 0.1, 1000.0
"""Slowest and fastest planning rates in Hz: one cycle per 10 s at the least (a stop must not wait
out a longer period), and no faster than a plant is stepped."""
MAX_OPT_ITERS = 100
"""Most optimizer iterations per planning cycle."""
MAX_ITERATIONS_PER_SECOND = 10_000.0
"""Most optimizer iterations per second of control that `iterations_per_second` may ask for."""
MAX_NUM_TRACES = 64
"""Most best-rollout traces drawn besides the nominal."""
MAX_RANDOMIZATIONS = 64
"""Most models each sampled control sequence is rolled out under."""
MAX_ROLLOUT_BYTES = 4 * 2**30
"""Largest rollout buffers (num_randomizations x num_rollouts x T x (nstate + nsensordata + nu)
float64) a config may ask for:
4 GiB, e.g. 65536 rollouts of 100 steps of a model with 80 state and sensor values."""


# Every slider range lies within the bounds `validate` accepts; the horizon (seconds) reads
# linearly.
@slider("horizon", 0.05, 5.0, 0.05, log=False)
@slider("control_freq", 1.0, 200.0, 1.0)
@slider("max_opt_iters", 1, 20, 1)
@slider("iterations_per_second", 0.0, 200.0, 1.0, log=False)
@slider("max_num_traces", 0, 32, 1)
@slider("num_randomizations", 1, 16, 1)
@slider("cvar_alpha", 0.05, 1.0, 0.05)
@slider("risk_scale", 0.1, 100.0, 0.1)
@slider("redraw_every", 0, 100, 1)
# from 0.05: 0 (the watchdog off) is set outside the GUI
@slider("max_plan_age", 0.05, 5.0, 0.05, log=False)
@slider("policy_samples", 0, 64, 1)
@dataclass
class ControllerConfig(Config):
    """Settings of the planning loop, shared by every task and optimizer."""

    horizon: float = 1.0
    """Planning horizon in seconds."""
    spline_order: SplineOrder = "linear"
    """How controls are interpolated between knots: zero-order hold, linear, or cubic (needs 4+
    knots)."""
    control_freq: float = 20.0
    """Planning cycles per second that the app aims for."""
    max_opt_iters: int = 1
    """Optimizer iterations per planning cycle (at least: see iterations_per_second)."""
    iterations_per_second: float = 20.0
    """Optimizer iterations per second of control, at least: each cycle runs `iterations_per_cycle`,
    the larger of max_opt_iters and ceil(iterations_per_second / control_freq) (at most
    MAX_OPT_ITERS), so a slower planning rate searches as much per second as a faster one (20 at 5
    Hz: 4 iterations a cycle, as 1 a cycle at 20 Hz); 0: max_opt_iters a cycle. At 20 Hz and faster
    the default changes nothing. Where a deadline is given (the app gives each cycle its control
    period), the iterations beyond max_opt_iters run only while they fit in it."""
    max_num_traces: int = 5
    """Best rollouts drawn as traces, besides the nominal."""
    num_randomizations: int = 1
    """Models each sampled control sequence is rolled out under: the planning model and
    num_randomizations - 1 copies perturbed by the task's randomize_model hook (1: off)."""
    risk: RiskMeasure = "average"
    """How a sequence's rewards under the randomized models become one score: average, worst, best,
    cvar (mean of the worst cvar_alpha fraction) or exponential (certainty equivalent,
    risk_scale)."""
    cvar_alpha: float = 0.5
    """Fraction of the models, the worst ones, that the cvar risk averages; in (0, 1]."""
    risk_scale: float = 1.0
    """Scale of the exponential risk, in 1 / reward units: > 0 risk-averse, < 0 risk-seeking; not
    0."""
    redraw_every: int = 0
    """Planning cycles between redraws of the randomized models; 0 draws them once (again only when
    num_randomizations changes)."""
    max_plan_age: float = 0.5
    """Watchdog, in seconds: once the plan in force is older than this beyond one control period
    (planning stalled, failed, or the readings' time stopped advancing), the plant gets the task's
    safe_action instead; 0 turns the watchdog off."""
    latency_compensation: bool = False
    """Plan from the state the plant will be in when the plan takes effect: the reading is stepped
    forward on the planning model by the planning latency (the fixed latency, else the last update's
    wall time), under the controls the plant gets meanwhile (judo.loop.timing)."""
    feedback: bool = False
    """Serve the plan with time-varying LQR gains around its nominal rollout, u = u_plan(t) + K(t)
    (x - x_nom(t)), clamped to the actuators' range: each update also linearises the planning model
    along the plan (judo.core.feedback) and the task's feedback_cost weighs the deviations. The plan
    is made from the reading predicted to when it takes effect, as with latency_compensation, so
    that its nominal starts where the plant will be. A task with a low-level policy gets its plans
    without gains (the status line says so)."""
    policy_samples: int = 0
    """Candidates of each update that come from the controller's proposal policy instead of the
    optimizer (generative predictive control): the last policy_samples of the num_rollouts, scored
    and ranked with the others, so worse ones are not chosen; at most num_rollouts - 1, 0 turns it
    off (judo.core.policies.proposals)."""

    @property
    def iterations_per_cycle(self) -> int:
        """Optimizer iterations each planning cycle runs (`iterations_per_second`)."""
        return cycle_iterations(self.max_opt_iters, self.iterations_per_second, self.control_freq)

    def validate(self) -> None:
        super().validate()
        require_between("horizon", self.horizon, 0, MAX_HORIZON, " s", above=True)
        require_between(
            "control_freq", self.control_freq, MIN_CONTROL_FREQ, MAX_CONTROL_FREQ, " Hz"
        )
        require_between("max_opt_iters", self.max_opt_iters, 1, MAX_OPT_ITERS)
        require_between(
            "iterations_per_second",
            self.iterations_per_second,
            0,
            MAX_ITERATIONS_PER_SECOND,
            " (0: off)",
        )
        require_between("max_num_traces", self.max_num_traces, 0, MAX_NUM_TRACES)
        require_between("num_randomizations", self.num_randomizations, 1, MAX_RANDOMIZATIONS)
        require(0 < self.cvar_alpha <= 1, f"cvar_alpha must be in (0, 1], got {self.cvar_alpha}")
        require(
            np.isfinite(self.risk_scale) and self.risk_scale != 0,
            "risk_scale must be a finite nonzero number (> 0 risk-averse, < 0 "
            f"risk-seeking), got {self.risk_scale}",
        )
        require(
            self.redraw_every >= 0,
            f"redraw_every must be at least 0 (0: draw once), got {self.redraw_every}",
        )
        require_between("max_plan_age", self.max_plan_age, 0, MAX_HORIZON, " s (0: no watchdog)")
        require_between("policy_samples", self.policy_samples, 0, MAX_NUM_ROLLOUTS - 1, " (0: off)")


def cycle_iterations(max_opt_iters: int, iterations_per_second: float, control_freq: float) -> int:
    """Optimizer iterations in one planning cycle: max_opt_iters, or more where
    iterations_per_second asks for more at this control_freq (Hz), up to MAX_OPT_ITERS (a slow rate,
    0.1 Hz, never asks for a cycle of 200)."""
    if iterations_per_second <= 0:
        return max_opt_iters
    return max(
        max_opt_iters, min(MAX_OPT_ITERS, math.ceil(iterations_per_second / control_freq - 1e-9))
    )


def rollout_steps(horizon: float, dt: float) -> int:
    """Rollout length T in steps for a `horizon` in seconds and a timestep `dt`: at least one,
    rounded."""
    return max(1, round(horizon / dt))


def check_configs(
    task: Task, controller_config: ControllerConfig, optimizer_config: OptimizerConfig
) -> None:
    """Raise ConfigError unless the configs work together on `task` (each is validated too)."""
    controller_config.validate()
    optimizer_config.validate()
    require(
        controller_config.horizon >= task.dt,
        f"horizon ({controller_config.horizon} s) is shorter than one timestep ({task.dt} s)",
    )
    samples, rollouts = controller_config.policy_samples, optimizer_config.num_rollouts
    require(
        samples < rollouts,
        f"policy_samples ({samples}) must be below num_rollouts ({rollouts}): the nominal, "
        "rollout 0, is never "
        f"replaced; expected 0 to {rollouts - 1}",
    )
    order, nodes = controller_config.spline_order, optimizer_config.num_nodes
    require(
        nodes >= MIN_KNOTS[order],
        f"a {order} spline needs num_nodes >= {MIN_KNOTS[order]}, got {nodes}",
    )
    num_steps = rollout_steps(controller_config.horizon, task.dt)
    state_size = mujoco.mj_stateSize(task.model, STATE_SPEC)  # pyright: ignore[reportAttributeAccessIssue]
    values_per_step = state_size + task.model.nsensordata + task.nu
    num_models = controller_config.num_randomizations
    needed = num_models * optimizer_config.num_rollouts * num_steps * values_per_step * 8
    most = max(1, MAX_ROLLOUT_BYTES // (num_models * num_steps * values_per_step * 8))
    require(
        needed <= MAX_ROLLOUT_BYTES,
        f"num_rollouts {optimizer_config.num_rollouts} x num_randomizations {num_models} over a "
        f"{controller_config.horizon} s horizon ({num_steps} steps) "
        f"would need {needed / 2**30:.1f} GiB of rollout buffers, more than the "
        f"{MAX_ROLLOUT_BYTES / 2**30:.0f} GiB "
        f"limit; at this horizon and num_randomizations, num_rollouts must be at most {most}",
    )
