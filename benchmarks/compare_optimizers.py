"""Compare optimizers on the built-in tasks: planning overhead against raw rollouts, and closed-loop success.

    PYTHONPATH=src python benchmarks/compare_optimizers.py
    PYTHONPATH=src python benchmarks/compare_optimizers.py --tasks cartpole --optimizers dial cmaes --seeds 0

Timing: median over `--timing-calls` calls of `Controller.update_action` and of `pool.rollout` on the same
(num_rollouts, T, nu) batch; ratio = update / (rollout * iterations per update); "opt us" is one
sample_control_knots + update_nominal_knots pair alone, the optimizer's own cost per iteration. Success (no latency, plan at control_freq):
cartpole, the fraction of the last 3 s of a 10 s episode with cos(angle) > 0.9 and |x| < 0.3;
cylinder_push, the cart-goal distance after 15 s. Every optimizer runs with the task's defaults.
"""

import argparse
import time

import numpy as np

import judo
from judo.runtime.system import MujocoSystem

EPISODE_SECONDS = {"cartpole": 10.0, "cylinder_push": 15.0}


def run_episode(task_name: str, optimizer_name: str, seed: int, overrides: dict) -> float:
    """Closed-loop success figure of one episode (see the module docstring)."""
    ctrl = judo.make_controller(task_name, optimizer_name, seed=seed)
    ctrl.config = judo.core.config.with_updates(ctrl.config, overrides)
    plant_task = type(ctrl.task)()
    plant_task.config = ctrl.task.config
    plant_task.rng = np.random.default_rng(1000 + seed)
    plant_task.reset()
    system = MujocoSystem(plant_task)
    next_plan, duration = 0.0, EPISODE_SECONDS[task_name]
    states = []
    while system.read_state().time < duration - 1e-9:
        reading = system.read_state()
        if reading.time >= next_plan - 1e-9:
            ctrl.update_action(reading.state, reading.time, reading.metadata)
            next_plan += 1.0 / ctrl.config.control_freq
        system.apply(ctrl.action(reading.time))
        system.step()
        states.append((system.read_state().time, system.read_state().state))
    ctrl.close()
    if task_name == "cartpole":
        tail = np.array([s for t, s in states if t > duration - 3.0])
        upright = (np.cos(tail[:, 1]) > 0.9) & (np.abs(tail[:, 0]) < 0.3)
        return float(upright.mean())
    final = states[-1][1]
    return float(np.linalg.norm(final[2:4] - plant_task.config.goal_pos))


def time_update(task_name: str, optimizer_name: str, calls: int, overrides: dict) -> tuple[float, float, int]:
    """(median update_action seconds, median rollout seconds, iterations per update).

    Update and rollout calls alternate, so both see the same machine load."""
    ctrl = judo.make_controller(task_name, optimizer_name, seed=0)
    ctrl.config = judo.core.config.with_updates(ctrl.config, overrides)
    state = np.concatenate([ctrl.task.data.qpos, ctrl.task.data.qvel])
    ctrl.update_action(state, 0.0)
    iterations = 0
    original = ctrl.optimizer.update_nominal_knots

    def counted(knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        nonlocal iterations
        iterations += 1
        return original(knots, rewards)

    ctrl.optimizer.update_nominal_knots = counted  # type: ignore[method-assign]
    update_times, rollout_times = [], []
    for i in range(calls):
        iterations = 0
        start = time.perf_counter()
        ctrl.update_action(state, 0.01 * (i + 1))
        update_times.append(time.perf_counter() - start)
        controls = np.ascontiguousarray(ctrl._controls)
        start = time.perf_counter()
        ctrl.pool.rollout(ctrl._initial_state, controls)
        rollout_times.append(time.perf_counter() - start)
    ctrl.close()
    return float(np.median(update_times)), float(np.median(rollout_times)), iterations


def time_optimizer_alone(task_name: str, optimizer_name: str, calls: int) -> float:
    """Median seconds of one sample_control_knots + update_nominal_knots pair, without rollouts."""
    ctrl = judo.make_controller(task_name, optimizer_name, seed=0)
    opt = ctrl.optimizer
    ctrl.close()
    times = np.linspace(0.0, ctrl.config.horizon, opt.num_nodes)
    nominal = np.zeros((opt.num_nodes, ctrl.task.nu))
    rng = np.random.default_rng(0)
    durations = []
    for _ in range(calls):
        rewards = rng.normal(size=opt.num_rollouts)
        start = time.perf_counter()
        opt.pre_optimization(times, times)
        knots = opt.sample_control_knots(nominal)
        nominal = opt.update_nominal_knots(knots, rewards)
        durations.append(time.perf_counter() - start)
    return float(np.median(durations))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=["cartpole", "cylinder_push"])
    parser.add_argument("--optimizers", nargs="+", default=["ps", "cem", "mppi", "dial", "cmaes", "icem"])
    parser.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2], help="none: timing only")
    parser.add_argument("--timing-calls", type=int, default=50)
    parser.add_argument("--max-opt-iters", type=int, default=None, help="override the controller's max_opt_iters")
    parser.add_argument("--no-timing", action="store_true")
    args = parser.parse_args()
    overrides = {} if args.max_opt_iters is None else {"max_opt_iters": args.max_opt_iters}
    print(
        f"{'task':14s} {'optimizer':9s} {'iters':>5s} {'update ms':>9s} {'rollout ms':>10s} {'ratio':>6s} "
        f"{'opt us':>7s}  success per seed"
    )
    for task_name in args.tasks:
        for optimizer_name in args.optimizers:
            if args.no_timing:
                update, rollout, iterations, alone = np.nan, np.nan, 0, np.nan
            else:
                update, rollout, iterations = time_update(task_name, optimizer_name, args.timing_calls, overrides)
                alone = time_optimizer_alone(task_name, optimizer_name, args.timing_calls)
            scores = [run_episode(task_name, optimizer_name, seed, overrides) for seed in args.seeds]
            ratio = update / (rollout * max(iterations, 1))
            print(
                f"{task_name:14s} {optimizer_name:9s} {iterations:5d} {1e3 * update:9.2f} {1e3 * rollout:10.2f} "
                f"{ratio:6.2f} {1e6 * alone:7.0f}  "
                + " ".join(f"{s:.3f}" for s in scores)
                + (f"  mean {np.mean(scores):.3f}" if scores else ""),
                flush=True,
            )


if __name__ == "__main__":
    main()
