import mujoco
import numpy as np
import pytest

import judo
from judo.core.task import EpisodeLog
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.tasks.push_t import PushT, PushTConfig, yaw_of


def place(
    task: PushT, block: tuple[float, float, float], pusher: tuple[float, float]
) -> np.ndarray:
    """Sensor row (nsensordata,) with the block at (x, y, heading) and the pusher at (x, y)."""
    task.data.qpos[:] = [*block, *pusher]
    mujoco.mj_forward(task.sim_model, task.data)
    return task.data.sensordata.copy()


def test_model_compiles_with_normalised_forces_traces_and_a_mocap_goal() -> None:
    task = PushT()
    assert (task.model.nq, task.nu, task.model.nmocap) == (5, 2, 1)
    np.testing.assert_array_equal(task.actuator_ctrlrange, [[-1.0, 1.0], [-1.0, 1.0]])
    assert {"trace_pusher", "trace_block"} <= {
        task.model.sensor(i).name for i in range(task.model.nsensor)
    }


def test_yaw_of_reads_headings_about_the_vertical() -> None:
    angles = np.array([0.0, 0.5, -2.0])
    quaternions = np.stack(
        [np.cos(angles / 2), 0 * angles, 0 * angles, np.sin(angles / 2)], axis=-1
    )
    np.testing.assert_allclose(yaw_of(quaternions), angles)


def test_reward_prefers_the_block_on_the_goal_pose_with_the_pusher_nearby() -> None:
    task = PushT()
    config = PushTConfig()
    rows = [
        place(task, (0.0, 0.0, 0.0), (0.0, -0.2)),  # on the goal
        place(task, (0.0, 0.0, 1.0), (0.0, -0.2)),  # on the goal position, turned
        place(task, (0.2, 0.0, 0.0), (0.32, 0.0)),  # off the goal, pusher behind it
        place(task, (0.2, 0.0, 0.0), (-0.3, 0.0)),  # off the goal, pusher on the wrong side
    ]
    sensors = np.array(rows)[:, None, :].repeat(3, axis=1)
    rewards = task.reward(np.zeros((4, 3, 10)), sensors, np.zeros((4, 3, 2)), config)
    assert rewards.shape == (4,)
    assert rewards[0] > rewards[1]
    assert rewards[0] > rewards[2] > rewards[3]


def test_reset_puts_the_block_away_from_the_goal_at_random() -> None:
    task = PushT()
    task.rng = np.random.default_rng(0)
    errors = []
    for _ in range(3):
        task.reset()
        position_error, _ = task.errors(task.data.sensordata)
        errors.append(float(position_error))
    assert all(0.15 - 1e-9 <= e <= 0.25 + 1e-9 for e in errors)
    assert len(set(errors)) == 3


def test_metrics_report_final_errors_and_the_placed_share() -> None:
    task = PushT()
    off, on = place(task, (0.1, 0.0, 0.5), (0.3, 0.3)), place(task, (0.01, 0.0, -0.05), (0.3, 0.3))
    sensors = np.array([off] * 3 + [on])
    log = EpisodeLog(np.arange(1, 5) * 0.01, np.zeros((4, 10)), np.zeros((4, 2)), sensors)
    metrics = task.metrics(log)
    assert metrics["final_position_error"] == pytest.approx(0.01)
    assert metrics["final_angle_error"] == pytest.approx(0.05)
    assert metrics["placed_fraction"] == pytest.approx(0.25)


@pytest.mark.slow
def test_predictive_sampling_pushes_the_block_onto_the_goal() -> None:
    controller = judo.make_controller("push_t", "ps", seed=0)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    log = run_episode(controller, plant, duration=5.0).log
    controller.close()
    metrics = plant.task.metrics(log)
    assert metrics["final_position_error"] < 0.05
    assert metrics["final_angle_error"] < 0.3
