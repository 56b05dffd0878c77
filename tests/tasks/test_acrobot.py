import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.acrobot import MODEL_PATH, TOP, Acrobot, AcrobotConfig


def rows(
    task: Acrobot, qpos: tuple[float, float], qvel: tuple[float, float] = (0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """(1, 3, 4) states and (1, 3, nsensordata) sensors holding one pose for three steps."""
    task.data.qpos[:], task.data.qvel[:] = qpos, qvel
    mujoco.mj_forward(task.sim_model, task.data)
    return np.tile([*qpos, *qvel], (1, 3, 1)), np.tile(task.data.sensordata, (1, 3, 1))


def test_model_compiles_with_one_normalised_elbow_torque_and_traces() -> None:
    task = Acrobot()
    assert (task.model.nq, task.nu) == (2, 1)
    np.testing.assert_array_equal(task.actuator_ctrlrange, [[-1.0, 1.0]])
    assert task.model.actuator_trnid[0, 0] == task.model.joint("elbow").id
    names = {task.model.sensor(i).name for i in range(task.model.nsensor)}
    assert {"trace_tip", "trace_elbow"} <= names


def test_upright_energy_is_the_potential_energy_straight_up() -> None:
    task = Acrobot()
    assert task.upright_energy == pytest.approx(9.81 * (1.0 * 0.5 + 1.0 * 1.5), rel=1e-3)
    _, sensors = rows(task, (0.0, 0.0))
    np.testing.assert_allclose(sensors[0, 0, :3], TOP, atol=1e-12)


def test_energy_of_a_state_matches_mujocos_own() -> None:
    task = Acrobot()
    model = mujoco.MjModel.from_xml_path(str(MODEL_PATH))
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    states = np.column_stack([rng.uniform(-np.pi, np.pi, (5, 2)), rng.normal(0.0, 3.0, (5, 2))])
    for state in states:
        data.qpos[:], data.qvel[:] = state[:2], state[2:]
        mujoco.mj_forward(model, data)
        assert task.energy.total(state) == pytest.approx(data.energy.sum(), rel=1e-9)
    np.testing.assert_allclose(
        task.energy.total(states[None]), [[task.energy.total(s) for s in states]]
    )


def test_balance_cost_is_zero_upright_grows_with_the_lean_and_saturates_far_away() -> None:
    task = Acrobot()
    states = np.array(
        [[0.0, 0.0, 0.0, 0.0], [0.01, 0.0, 0.0, 0.0], [0.03, 0.0, 0.0, 0.0], [np.pi, 0.0, 0.0, 0.0]]
    )
    cost = task.balance_cost(states)
    assert cost[0] == 0.0
    assert 0.0 < cost[1] < cost[2] < 1.0
    assert cost[3] == 1.0
    assert task.balance_cost(np.array([2 * np.pi + 0.01, 0.0, 0.0, 0.0])) == pytest.approx(cost[1])
    assert np.all(np.linalg.eigvalsh(task.balance_matrix) > 0)


def test_reward_prefers_upright_over_folded_over_hanging() -> None:
    task = Acrobot()
    cases = [
        rows(task, (0.0, 0.0)),
        rows(task, (np.pi, np.pi)),
        rows(task, (np.pi, 0.0)),
        rows(task, (0.0, 0.0), (2.0, 0.0)),
    ]
    states = np.concatenate([c[0] for c in cases])
    sensors = np.concatenate([c[1] for c in cases])
    rewards = task.reward(states, sensors, np.zeros((4, 3, 1)), AcrobotConfig())
    assert rewards.shape == (4,)
    assert rewards[0] == pytest.approx(0.0, abs=1e-9)
    assert rewards[0] > rewards[3]
    assert rewards[0] > rewards[1] > rewards[2]


def test_reset_hangs_both_links_down_at_random() -> None:
    task = Acrobot()
    task.rng = np.random.default_rng(0)
    task.reset()
    first = task.data.qpos.copy()
    task.reset()
    assert not np.allclose(first, task.data.qpos)
    assert task.data.sensordata[task.get_sensor_start_index("trace_tip") + 2] < -1.9


def test_metrics_measure_the_upright_share_of_the_last_three_seconds() -> None:
    task = Acrobot()
    times = np.arange(1, 501) * 0.01  # 5 s
    sensors = np.zeros((500, task.model.nsensordata))
    sensors[:, 2] = np.where(times > 3.5, 1.9, -2.0)  # tip 0.1 m below the top for the last 1.5 s
    metrics = task.metrics(EpisodeLog(times, np.zeros((500, 4)), np.zeros((500, 1)), sensors))
    assert metrics["upright_fraction"] == pytest.approx(0.5, abs=0.01)
    assert metrics["final_tip_distance"] == pytest.approx(0.1)


@pytest.mark.slow
def test_cem_swings_the_acrobot_up_and_holds_it() -> None:
    controller = judo.make_controller("acrobot", "cem", seed=0)
    log = run_episode(controller, MujocoSystem.from_task(controller.task, seed=0), duration=8.0).log
    controller.close()
    distance = np.linalg.norm(log.sensors[:, :3] - TOP, axis=-1)
    last = log.times > log.times[-1] - 1.5
    assert distance.min() < 0.2
    assert np.mean(distance[last] < 0.2) > 0.5  # up within 6 s (seed 0) and balancing since
