"""The built-in tasks on their own dynamics: the car's kinematic bicycle and the quadrotor's rigid
body, their drawing models, and each reaching a goal in closed loop."""

import numpy as np
import pytest

import judo
from judo.core.rollouts.dynamics import DynamicsRollout, drawn_model, drawn_qpos
from judo.evaluation.episode import run_episode
from judo.loop.system import DynamicsSystem, MujocoSystem
from judo.tasks.car import LF, LR, MAX_ACCEL, MAX_STEER, Car, penetration
from judo.tasks.quadrotor import HOVER, MASS, Quadrotor, z_axis


def test_the_car_follows_the_kinematic_bicycle():
    """Straight ahead the car speeds up by the acceleration; at full lock it turns at v / lr
    sin(beta)."""
    car = Car()
    state = np.array([[0.0, 0.0, 0.0, 2.0]])
    ahead = car.dynamics(state, np.array([[1.0, 0.0]]), 0.02)[0]
    assert ahead == pytest.approx([0.04, 0.0, 0.0, 2.0 + 0.02 * MAX_ACCEL])
    turned = car.dynamics(state, np.array([[0.0, 1.0]]), 0.02)[0]
    slip = np.arctan(LR / (LF + LR) * np.tan(MAX_STEER))
    assert turned[2] == pytest.approx(0.02 * 2.0 / LR * np.sin(slip))
    assert penetration(np.array([[1.2, 1.0], [0.0, 0.0]])).tolist() == pytest.approx([0.55, 0.0])


def test_the_quadrotor_hovers_and_tilts_the_right_way():
    quad = Quadrotor()
    start = np.array([[0.0, 0.0, 1.0, 1.0, 0, 0, 0, *np.zeros(6)]])
    x = start
    for _ in range(100):
        x = quad.dynamics(x, np.full((1, 4), HOVER), 0.01)
    assert x[0] == pytest.approx(start[0], abs=1e-9)  # hover thrust holds it still
    more_at_the_back = np.array([[1.1, 1.1, 0.9, 0.9]]) * HOVER  # rotors 1, 2 sit at x = -0.14 m
    for _ in range(20):
        x = quad.dynamics(x, more_at_the_back, 0.01)
    assert z_axis(x[0, 3:7])[0] > 0.01  # pitched nose down: thrust tips forward
    assert x[0, 10] == pytest.approx(0.0, abs=1e-12) and x[0, 11] > 0.0
    assert np.linalg.norm(x[0, 3:7]) == pytest.approx(1.0)
    assert MASS * 9.81 == pytest.approx(4 * 13.0 * HOVER)


@pytest.mark.parametrize("task_cls", [Car, Quadrotor])
def test_the_drawing_model_shows_the_plant(task_cls):
    task = task_cls()
    model = drawn_model(task)
    # the goal, in both, so the GUI's drag reaches the plant
    assert model.nmocap == task.model.nmocap == 1
    qpos = drawn_qpos(task, np.concatenate([task.data.qpos, task.data.qvel]))
    assert qpos.shape == (model.nq,)
    assert np.array_equal(qpos[:2], task.state[:2])
    assert model.body(type(task).focus_body).id > 0


def test_the_car_reaches_goals_without_touching_an_obstacle():
    controller = judo.make_controller("car", "mppi", seed=0)
    system = MujocoSystem.from_task(controller.task, seed=0)
    assert isinstance(system, DynamicsSystem) and isinstance(controller.backend, DynamicsRollout)
    with controller:
        result = run_episode(controller, system, duration=6.0)
    assert result.metrics["goals_reached"] >= 1
    assert result.metrics["collision_fraction"] == 0.0


@pytest.mark.slow
def test_the_quadrotor_reaches_a_goal_pose():
    controller = judo.make_controller("quadrotor", "mppi", seed=0)
    with controller:
        result = run_episode(
            controller, MujocoSystem.from_task(controller.task, seed=0), duration=8.0
        )
    assert result.metrics["goals_reached"] >= 1
    assert result.metrics["crashes"] == 0


def test_the_car_drives_to_a_goal_moved_on_the_plant():
    """What the GUI's drag does (app.commands.move_goal, through the plant's System.move_goal): the
    planner sees the goal in the plant's published metadata and the car drives there."""
    controller = judo.make_controller("car", "mppi", seed=1)
    controller.task.config.new_goal_on_reach = False
    plant = MujocoSystem.from_task(controller.task, seed=1)
    plant.task.data.mocap_pos[0, :2] = [-2.0, 0.2]
    with controller:
        loop = judo.ClosedLoop(controller, plant)
        loop.restart()
        while loop.reading.time < 5.0:
            loop.step()
    assert np.linalg.norm(plant.task.state[:2] - [-2.0, 0.2]) < 0.2
