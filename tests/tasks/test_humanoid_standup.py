import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.humanoid_standup import HumanoidStandup, HumanoidStandupConfig


def rollout_rows(
    task: HumanoidStandup, qpos: np.ndarray, qvel: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(1, 3, nq + nv) states and (1, 3, nsensordata) sensors holding one pose for three steps."""
    task.data.qpos[:] = qpos
    task.data.qvel[:] = 0.0 if qvel is None else qvel
    mujoco.mj_forward(task.sim_model, task.data)
    state = np.concatenate([task.data.qpos, task.data.qvel])
    return np.tile(state, (1, 3, 1)), np.tile(task.data.sensordata, (1, 3, 1))


def test_model_compiles_with_a_free_root_sixteen_normalised_torques_and_traces() -> None:
    task = HumanoidStandup()
    assert (task.model.nq, task.model.nv, task.nu) == (23, 22, 16)
    np.testing.assert_array_equal(task.actuator_ctrlrange, np.tile([-1.0, 1.0], (16, 1)))
    names = {task.model.sensor(i).name for i in range(task.model.nsensor)}
    assert {"trace_head", "trace_right_foot", "trace_left_foot"} <= names
    assert task.model.ngeom and all(task.model.geom_type != mujoco.mjtGeom.mjGEOM_MESH)


def test_reset_lays_it_on_its_back_at_a_random_heading() -> None:
    task = HumanoidStandup()
    task.rng = np.random.default_rng(0)
    task.reset()
    first = task.data.qpos[3:7].copy()
    assert task.head_height(task.data.sensordata) < 0.3
    assert task.data.time == 0.0
    task.reset()
    assert not np.allclose(first, task.data.qpos[3:7])


def test_reward_prefers_standing_still_to_lying_leaning_or_hopping() -> None:
    task = HumanoidStandup()
    config = HumanoidStandupConfig()
    standing = task.model.qpos0.copy()
    lying = standing.copy()
    lying[2], lying[3:7] = 0.1 - 1.12, [np.cos(-np.pi / 4), 0.0, np.sin(-np.pi / 4), 0.0]
    hopping = standing.copy()
    hopping[2] += 0.4
    drifting = np.zeros(task.model.nv)
    drifting[0] = 1.0
    cases = [
        rollout_rows(task, standing),
        rollout_rows(task, lying),
        rollout_rows(task, hopping),
        rollout_rows(task, standing, drifting),
    ]
    states = np.concatenate([c[0] for c in cases])
    sensors = np.concatenate([c[1] for c in cases])
    rewards = task.reward(states, sensors, np.zeros((4, 3, 16)), config)
    assert rewards.shape == (4,)
    assert rewards[0] > rewards[2] > rewards[1]
    assert rewards[0] > rewards[3]


def test_metrics_need_the_head_held_up_for_a_second() -> None:
    task = HumanoidStandup()
    times = np.arange(1, 501) * 0.01  # 5 s
    head = np.full(500, 0.3)
    head[50:80] = 1.3  # a hop: 0.3 s up
    head[200:] = 1.35  # up for good from t = 2.01 s
    sensors = np.zeros((500, task.model.nsensordata))
    sensors[:, task.get_sensor_start_index("trace_head") + 2] = head
    metrics = task.metrics(EpisodeLog(times, np.zeros((500, 45)), np.zeros((500, 16)), sensors))
    assert metrics["time_to_stand"] == pytest.approx(2.01)
    assert metrics["standing_fraction"] == pytest.approx(330 / 500)
    assert metrics["standing_after_up"] == pytest.approx(1.0)
    assert metrics["final_head_height"] == pytest.approx(1.35)


@pytest.mark.slow
def test_mppi_gets_the_humanoid_off_the_floor() -> None:
    controller = judo.make_controller("humanoid_standup", "mppi", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=3.0).log
    controller.close()
    head = plant.task.head_height(log.sensors)
    assert head[log.times > 2.0].max() > 1.0
