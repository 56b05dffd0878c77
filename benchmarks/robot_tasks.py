"""Closed-loop figures and update timing for the robot tasks (leap_cube, leap_cube_down, fr3_pick).

For each seed it runs the task's default settings with no latency: the plant (a second task instance on
`sim_model`) steps at its own timestep and the controller replans every 1 / control_freq seconds of sim
time. It prints the plant task's metrics per seed and their mean, with the median wall time of
`Controller.update_action` next to the raw `RolloutPool.rollout` of the same (num_rollouts, T) batch
(timed in alternation after the episode, from its final state).

    PYTHONPATH=src python benchmarks/robot_tasks.py leap_cube cem --seconds 60 --seeds 0 1 2
    PYTHONPATH=src python benchmarks/robot_tasks.py fr3_pick ps --seconds 20 --seeds 0 1 --plant models/x.xml
"""

import argparse
import time

import mujoco
import numpy as np

import judo
from judo.core.model import STATE_SPEC
from judo.core.task import EpisodeLog
from judo.runtime.system import MujocoSystem, SimulationDiverged


def run_episode(
    task_name: str, optimizer_name: str, seconds: float, seed: int, plant_path: str | None, timing_repeats: int = 30
) -> dict:
    """One episode; returns the plant's metrics plus the median update and raw-rollout times in ms."""
    ctrl = judo.make_controller(task_name, optimizer_name, seed=seed)
    plant = type(ctrl.task)() if plant_path is None else type(ctrl.task)(sim_model_path=plant_path)
    plant.config = ctrl.task.config
    plant.rng = np.random.default_rng(seed + 1000)
    plant.reset()
    system = MujocoSystem(plant)
    rows: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []
    next_plan, diverged = 0.0, 0
    for _ in range(round(seconds / system.timestep)):
        state = system.read_state()
        if state.time >= next_plan - 1e-9:
            ctrl.update_action(state.state, state.time, state.metadata)
            next_plan += 1.0 / ctrl.config.control_freq
        action = ctrl.action(state.time)
        system.apply(action)
        try:
            system.step()
        except SimulationDiverged:
            diverged += 1
        data = plant.data
        rows.append((data.time, np.concatenate([data.qpos, data.qvel]), action, data.sensordata.copy()))
    log = EpisodeLog(*(np.array(column) for column in zip(*rows, strict=True)))
    # Update time against its floor, the raw rollout of the same (num_rollouts, T) batch, timed in
    # alternation from the final plant state so both see the same machine load.
    state = system.read_state()
    initial = np.zeros(mujoco.mj_stateSize(plant.sim_model, STATE_SPEC))
    mujoco.mj_getState(plant.sim_model, plant.data, initial, STATE_SPEC)
    mocap = np.concatenate([plant.data.mocap_pos.ravel(), plant.data.mocap_quat.ravel()])
    controls = np.tile(action, (ctrl.optimizer.num_rollouts, ctrl.num_steps, 1))
    update_times, rollout_times = [], []
    for _ in range(timing_repeats):
        start = time.perf_counter()
        ctrl.update_action(state.state, state.time, state.metadata)
        update_times.append(time.perf_counter() - start)
        start = time.perf_counter()
        ctrl.pool.rollout(initial, controls, mocap)
        rollout_times.append(time.perf_counter() - start)
    ctrl.close()
    figures = plant.metrics(log)
    figures.update(
        diverged=float(diverged),
        update_ms=1e3 * float(np.median(update_times)),
        rollout_ms=1e3 * float(np.median(rollout_times)),
    )
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("task", choices=["leap_cube", "leap_cube_down", "fr3_pick"])
    parser.add_argument("optimizer", choices=sorted(judo.get_registered_optimizers()))
    parser.add_argument("--seconds", type=float, default=60.0, help="episode length in sim seconds")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--plant", default=None, help="plant model path (default: the task's own)")
    args = parser.parse_args()
    results = []
    for seed in args.seeds:
        start = time.perf_counter()
        figures = run_episode(args.task, args.optimizer, args.seconds, seed, args.plant)
        results.append(figures)
        shown = ", ".join(f"{key}={value:.3g}" for key, value in figures.items())
        print(
            f"{args.task} {args.optimizer} seed {seed}: {shown}  (wall {time.perf_counter() - start:.0f} s)", flush=True
        )
    mean = {key: float(np.nanmean([r[key] for r in results])) for key in results[0]}
    print(
        f"{args.task} {args.optimizer} mean over {len(results)} seeds x {args.seconds:g} s: "
        + ", ".join(f"{key}={value:.3g}" for key, value in mean.items())
    )


if __name__ == "__main__":
    main()
