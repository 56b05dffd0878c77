"""A no-latency closed loop for the task behaviour tests: plan at control_freq, step the plant, log it."""

import numpy as np

import judo
from judo.core.task import EpisodeLog, Task
from judo.runtime.system import MujocoSystem


def run_episode(
    task_name: str, optimizer_name: str, duration: float, seed: int = 0, num_workers: int = 2
) -> tuple[Task, EpisodeLog]:
    """Drive a fresh plant of `task_name` for `duration` s with the default settings of `optimizer_name`.

    Returns the plant task (its `metrics` reads the log) and the episode's EpisodeLog.
    """
    ctrl = judo.make_controller(task_name, optimizer_name, seed=seed, num_workers=num_workers)
    plant = type(ctrl.task)()
    plant.config = ctrl.task.config
    plant.rng = np.random.default_rng(seed + 100)
    plant.reset()
    system = MujocoSystem(plant)
    times, states, controls, sensors = [], [], [], []
    next_plan = 0.0
    try:
        while system.read_state().time < duration:
            reading = system.read_state()
            if reading.time >= next_plan - 1e-9:
                ctrl.update_action(reading.state, reading.time, reading.metadata)
                next_plan += 1.0 / ctrl.config.control_freq
            action = ctrl.action(reading.time)
            system.apply(action)
            system.step()
            data = plant.data
            times.append(data.time)
            states.append(np.concatenate([data.qpos, data.qvel]))
            controls.append(action.copy())
            sensors.append(data.sensordata.copy())
    finally:
        ctrl.close()
    return plant, EpisodeLog(np.array(times), np.array(states), np.array(controls), np.array(sensors))
