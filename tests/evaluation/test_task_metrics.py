import numpy as np
import pytest

from judo.core.task import EpisodeLog
from judo.tasks.cartpole import Cartpole
from judo.tasks.cylinder_push import CylinderPush


def log_of(states: np.ndarray, dt: float) -> EpisodeLog:
    steps = len(states)
    return EpisodeLog(
        dt * np.arange(1, steps + 1), states, np.zeros((steps, 1)), np.zeros((steps, 3))
    )


def test_cartpole_counts_the_final_three_seconds_upright_and_centred():
    dt, steps = 0.01, 1000  # 10 s; the last 3 s are the final 300 steps
    states = np.zeros((steps, 4))
    states[:, 1] = np.pi  # hanging
    states[-240:, 1] = 0.1  # upright for the last 2.4 s (cos 0.1 > 0.9)
    metrics = Cartpole().metrics(log_of(states, dt))
    assert metrics["balanced_fraction"] == pytest.approx(0.8)
    assert metrics["swung_up"] == 0.0


def test_cartpole_upright_but_off_centre_does_not_count():
    states = np.zeros((500, 4))
    states[:, 0] = 0.5
    assert Cartpole().metrics(log_of(states, 0.01)) == {"balanced_fraction": 0.0, "swung_up": 0.0}
    states[:, 0] = 0.1
    assert Cartpole().metrics(log_of(states, 0.01)) == {"balanced_fraction": 1.0, "swung_up": 1.0}


def test_cylinder_push_reports_the_final_distance_to_the_goal():
    task = CylinderPush()
    task.config.goal_pos = np.array([0.2, -0.1])
    states = np.zeros((3, 8))
    states[-1, 2:4] = [0.23, -0.14]  # 0.05 from the goal
    metrics = task.metrics(log_of(states, 0.02))
    assert metrics["final_distance"] == pytest.approx(0.05)
    states[-1, 2:4] = [0.22, -0.1]
    assert task.metrics(log_of(states, 0.02)) == {
        "final_distance": pytest.approx(0.02),
        "reached": 1.0,
    }
