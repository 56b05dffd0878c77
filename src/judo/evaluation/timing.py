"""Timing the control update against its floor: the raw rollout of the same N x R x T steps on the
same pool.

The control update samples knots, interpolates them, rolls them out (each sequence under each of the
R randomized models; R = 1 without randomization), scores and updates; the raw rollout is only
`controller.backend.rollout(initial_state, controls, mocap)` with controls of the same (R *
num_rollouts, T, nu) shape, on the same models. An update rolls out one such batch per optimizer
iteration, so the floor of the same work is max_opt_iters raw rollouts, and the update's ratio to
that floor is the controller's overhead on top of physics.
"""

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.config import require, with_updates
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import lookup_optimizer, make_config, make_controller
from judo.core.controller import Controller
from judo.core.model import STATE_SPEC
from judo.core.reading import SystemState, mocap_vector, model_at
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem


@dataclass
class UpdateTiming:
    """Wall times of one task x optimizer pair, in milliseconds.

    Attributes:
        task, optimizer: registered names.
        num_rollouts, num_steps: the batch, N rollouts of T steps each.
        num_randomizations: R, the models each rollout runs under (so R * N rollouts per batch).
        num_workers: rollout threads of the pool.
        max_opt_iters: optimizer iterations (each one batch of rollouts) per update.
        update_ms: (samples,) wall time of each timed control update.
        raw_rollout_ms: (samples,) wall time of each raw rollout of N x R x T steps on the same
            pool, timed alternately with the updates so both see the same machine load.
        backend: the rollout backend's name ("cpu" or "warp").
    """

    task: str
    optimizer: str
    num_rollouts: int
    num_steps: int
    num_workers: int
    max_opt_iters: int
    update_ms: np.ndarray
    raw_rollout_ms: np.ndarray
    backend: str = "cpu"
    num_randomizations: int = 1

    def floor_ms(self) -> float:
        """The physics an update cannot avoid: the median raw rollout times max_opt_iters (one batch
        per iteration)."""
        return self.max_opt_iters * float(np.median(self.raw_rollout_ms))

    def overhead_ratio(self) -> float:
        """Median update time over `floor_ms`, the raw rollouts of the same work (1.0: no overhead).
        An optimizer that ends its cycle early (stop_cond) can score below 1."""
        return float(np.median(self.update_ms)) / self.floor_ms()

    def fixed_cost_us(self) -> float:
        """The update's cost beyond its physics, in microseconds: the median update minus
        `floor_ms`."""
        return 1e3 * (float(np.median(self.update_ms)) - self.floor_ms())

    def row(self) -> dict[str, Any]:
        """The JSON row of `python -m judo benchmark --json`."""
        return {
            "task": self.task,
            "optimizer": self.optimizer,
            "num_rollouts": self.num_rollouts,
            "T": self.num_steps,
            "num_randomizations": self.num_randomizations,
            "num_workers": self.num_workers,
            "backend": self.backend,
            "max_opt_iters": self.max_opt_iters,
            "median_ms": float(np.median(self.update_ms)),
            "mean_ms": float(np.mean(self.update_ms)),
            "std_ms": float(np.std(self.update_ms)),
            "min_ms": float(np.min(self.update_ms)),
            "max_ms": float(np.max(self.update_ms)),
            "q25_ms": float(np.percentile(self.update_ms, 25)),
            "q75_ms": float(np.percentile(self.update_ms, 75)),
            "raw_rollout_ms": float(np.median(self.raw_rollout_ms)),
            "floor_ms": self.floor_ms(),
            "overhead_ratio": self.overhead_ratio(),
            "fixed_cost_us": self.fixed_cost_us(),
        }


def benchmark_controller(
    task_name: str,
    optimizer_name: str,
    *,
    num_rollouts: int | None = None,
    num_nodes: int | None = None,
    horizon: float | None = None,
    num_workers: int | None = None,
    seed: int = 0,
    backend: str = "cpu",
    controller_updates: dict[str, Any] | None = None,
) -> Controller:
    """A seeded controller on `backend` with the task's default settings, except the sizes and the
    ControllerConfig fields (`controller_updates`, e.g. {"num_randomizations": 4}) given here."""
    updates = dict(controller_updates or {})
    if horizon is not None:
        updates["horizon"] = horizon
    controller_config = with_updates(
        make_config(ControllerConfig, task_name, optimizer_name), updates
    )
    optimizer_config = make_config(lookup_optimizer(optimizer_name)[1], task_name)
    sizes = {"num_rollouts": num_rollouts, "num_nodes": num_nodes}
    optimizer_config = with_updates(
        optimizer_config, {k: v for k, v in sizes.items() if v is not None}
    )
    return make_controller(
        task_name,
        optimizer_name,
        controller_config=controller_config,
        optimizer_config=optimizer_config,
        num_workers=num_workers,
        seed=seed,
        backend=backend,
    )


def rollout_start(
    model: mujoco.MjModel, state: np.ndarray, time: float, metadata: dict
) -> tuple[np.ndarray, np.ndarray]:
    """What `RolloutPool.rollout` starts from for [qpos, qvel] `state` and mocap poses in
    `metadata`: the (nstate,) full-physics state and the (7 * nmocap,) mocap vector, as the
    controller builds them."""
    data = model_at(model, mujoco.MjData(model), state, time, metadata, forward=False)
    initial = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial, STATE_SPEC)
    return initial, mocap_vector(data)


def time_control_update(
    controller: Controller,
    samples: int,
    warmup: int = 10,
    seed: int = 0,
    on_sample: Callable[[], None] | None = None,
    clock: Callable[[], float] = time.perf_counter,
) -> tuple[np.ndarray, np.ndarray]:
    """Time `samples` control updates and as many raw rollouts of the same batch, after `warmup` of
    each.

    `on_sample` is called after each timed pair (not during the warm-up), e.g. to advance a progress
    bar. `clock` reads seconds: wall time by default; `time.thread_time` measures the calling
    thread's CPU time, which a loaded machine disturbs far less (all the work runs on the calling
    thread with one worker).

    Every update is the closed loop's `plan` from the task's start state for `seed` (its randomised
    reset), one control period later than the one before, so the plan shifts as in a running loop.
    The raw rollouts start from the same state and roll out the batch the last warm-up update rolled
    out (`controller.batch_controls`), on `controller.backend`.

    Returns:
        update_ms (samples,) and raw_rollout_ms (samples,), wall times in milliseconds.
    """
    require(samples >= 1, f"samples must be at least 1, got {samples}")
    require(warmup >= 0, f"warmup must be at least 0, got {warmup}")
    loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed))
    start = loop.restart()
    period = 1.0 / controller.config.control_freq
    plan_time = start.time

    # one control update from the start state, one control period after the last
    def update() -> None:
        nonlocal plan_time
        loop.plan(SystemState(start.state, plan_time, start.metadata))
        plan_time += period

    for _ in range(warmup + 1):  # at least one update, so the plan and the batch exist
        update()
    # (R * num_rollouts, T, nu), as the updates roll out
    controls = controller.batch_controls.copy()
    initial, mocap = rollout_start(controller.task.model, start.state, plan_time, start.metadata)
    for _ in range(warmup):
        controller.backend.rollout(initial, controls, mocap)

    update_ms, raw_ms = np.zeros(samples), np.zeros(samples)
    for i in range(samples):
        started = clock()
        update()
        update_ms[i] = 1e3 * (clock() - started)
        started = clock()
        controller.backend.rollout(initial, controls, mocap)
        raw_ms[i] = 1e3 * (clock() - started)
        if on_sample is not None:
            on_sample()
    return update_ms, raw_ms


def time_pair(
    task_name: str,
    optimizer_name: str,
    samples: int,
    *,
    warmup: int = 10,
    num_rollouts: int | None = None,
    num_nodes: int | None = None,
    horizon: float | None = None,
    num_workers: int | None = None,
    backend: str = "cpu",
    on_sample: Callable[[], None] | None = None,
    controller_updates: dict[str, Any] | None = None,
    clock: Callable[[], float] = time.perf_counter,
) -> UpdateTiming:
    """Build a controller for the pair on `backend` (default settings except the sizes and
    controller fields given), time it on `clock` (see `time_control_update`), close it."""
    with benchmark_controller(
        task_name,
        optimizer_name,
        num_rollouts=num_rollouts,
        num_nodes=num_nodes,
        horizon=horizon,
        num_workers=num_workers,
        backend=backend,
        controller_updates=controller_updates,
    ) as controller:
        update_ms, raw_ms = time_control_update(
            controller, samples, warmup, on_sample=on_sample, clock=clock
        )
    return UpdateTiming(
        task=task_name,
        optimizer=optimizer_name,
        num_rollouts=controller.optimizer.num_rollouts,
        num_steps=controller.num_steps,
        num_randomizations=len(controller.models),
        num_workers=controller.backend.num_workers,
        max_opt_iters=controller.config.iterations_per_cycle,
        update_ms=update_ms,
        raw_rollout_ms=raw_ms,
        backend=backend,
    )
