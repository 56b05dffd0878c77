"""The Unitree tasks' estimators on the shipped models, from what rt/lowstate carries (a robot's
noise, 500 Hz, 2 ms late): the Go2 standing up from its lying start, the G1 standing, each held by
its servos alone at the standing pose's targets (no planner), the base estimate against the
simulated truth. The Go2 plans from the EKF (with its TOML's noise), the G1 from the legged
estimator (benchmarks/base_estimation.py measures why)."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.configuration.registry import make_estimator
from judo.core.estimator import ControlHistory
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem

SENSING = {
    "noise": {
        "jointpos": 0.005,
        "jointvel": 0.1,
        "framequat": float(np.deg2rad(0.5)),
        "gyro": 0.01,
        "accelerometer": 0.1,
        "touch": 5.0,
    },
    "rate": 500.0,
    "delay": 0.002,
}
"""benchmarks/base_estimation.py's ROBOT: encoders 5 mrad and 0.1 rad/s, IMU 0.5 deg, 0.01 rad/s,
0.1 m/s^2, feet 5 N."""


def held(task_name: str, estimator_name: str, steps: int, skip: int) -> np.ndarray:
    """(steps - skip, 4) |height error| m, attitude error deg, |velocity error| m/s and planar
    distance m of `estimator_name` (with the task's TOML settings), its plant (seed 0) served the
    task's safe action every step."""
    task_cls = judo.get_registered_tasks()[task_name][0]
    planner = task_cls()
    plant = MujocoSystem.from_task(planner, 0)
    system = SensedSystem(plant, **SENSING, rng=np.random.default_rng(0))  # type: ignore[arg-type]
    estimator = make_estimator(estimator_name, planner, task_name=task_name)
    controls = ControlHistory(planner.nu)
    estimator.reset(system.read_state())
    nq, data = plant.task.sim_model.nq, plant.task.data
    rows = []
    for k in range(steps):
        action = planner.safe_action(np.concatenate([data.qpos, data.qvel]))
        controls.append(system.time, action)
        system.apply(action)
        system.step()
        state = estimator.update(system.read_state(), system.time, controls).state
        rotation = np.zeros(3)
        mujoco.mju_subQuat(rotation, state[3:7], data.qpos[3:7])
        if k >= skip:
            rows.append(
                (
                    abs(state[2] - data.qpos[2]),
                    np.rad2deg(np.linalg.norm(rotation)),
                    np.linalg.norm(state[nq : nq + 3] - data.qvel[:3]),
                    np.linalg.norm(state[:2] - data.qpos[:2]),
                )
            )
    return np.array(rows)


@pytest.mark.parametrize(
    ("task_name", "estimator"),
    [("go2_stand", "legged"), ("go2_walk", "legged"), ("g1_stand", "legged")],
)
def test_each_unitree_task_names_its_estimator(task_name, estimator):
    assert judo.get_registered_tasks()[task_name][0].default_estimator == estimator


@pytest.mark.slow
def test_the_go2_s_ekf_keeps_its_height_attitude_and_velocity_as_it_stands_up():
    # 1.5 s at 0.01 s: up from the floor in the first second
    errors = held("go2_stand", "ekf", steps=150, skip=10)
    mean, worst = errors.mean(axis=0), errors.max(axis=0)
    # Measured: height 0.6 (11) mm, attitude 0.25 (2.2) deg, velocity 0.029 (0.31) m/s, drift 18 mm.
    assert mean[0] < 0.003 and worst[0] < 0.03, (mean, worst)  # m
    assert mean[1] < 0.6 and worst[1] < 4.0, (mean, worst)  # deg
    assert mean[2] < 0.08 and worst[2] < 0.8, (mean, worst)  # m/s
    assert errors[-1, 3] < 0.05, errors[-1]  # m


@pytest.mark.slow  # a few seconds: the Go2's model and 200 steps of it
def test_the_legged_estimator_keeps_a_go2_s_height_attitude_and_velocity_as_it_stands_up():
    # 2 s at 0.01 s: up from the floor in the first second
    errors = held("go2_stand", "legged", steps=200, skip=10)
    mean, worst = errors.mean(axis=0), errors.max(axis=0)
    # Measured: height 0.5 (4.0) mm, attitude 0.17 (0.35) deg, velocity 0.018 (0.15) m/s, drift 16
    # mm.
    assert mean[0] < 0.003 and worst[0] < 0.012, (mean, worst)  # m
    assert mean[1] < 0.6 and worst[1] < 1.5, (mean, worst)  # deg: the IMU's 0.5 deg per axis
    assert mean[2] < 0.05 and worst[2] < 0.3, (mean, worst)  # m/s: the base rises at up to 0.5 m/s
    assert errors[-1, 3] < 0.05, errors[-1]  # m


@pytest.mark.slow  # a few seconds: the G1's model and 100 steps of it
def test_the_legged_estimator_keeps_a_standing_g1_s_height_attitude_and_velocity():
    # 1 s: before the servos alone let it topple
    errors = held("g1_stand", "legged", steps=100, skip=10)
    mean, worst = errors.mean(axis=0), errors.max(axis=0)
    # Measured: height 0.4 (0.9) mm, attitude 0.24 (0.40) deg, velocity 0.040 (0.096) m/s.
    assert mean[0] < 0.003 and worst[0] < 0.01, (mean, worst)
    assert mean[1] < 0.6 and worst[1] < 1.5, (mean, worst)
    assert mean[2] < 0.1 and worst[2] < 0.25, (mean, worst)
