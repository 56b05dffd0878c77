"""gait-search on the G1: its balance layout reads g1_stand's 14-value observation (gyro, gravity,
velocity in the pelvis frame, a zero command and a constant clock), tunes only the legs' and
waist's offsets and gains, and its episodes start with a kick of the size of g1_stand's pushes."""

import mujoco
import numpy as np

from judo.learning.gait_search import g1_problem
from judo.learning.policy_search import GaitEpisodes, GaitSearchSettings, search_gait
from judo.tasks.gait_policy import gait_actions
from judo.tasks.unitree import g1


def test_the_observation_is_the_pelvis_s_gyro_gravity_and_velocity_in_its_own_frame():
    task = g1.G1Stand(policy_path=None)
    nq, rng = task.model.nq, np.random.default_rng(0)
    states = rng.normal(size=(4, nq + task.model.nv))
    states[:, 3:7] /= np.linalg.norm(states[:, 3:7], axis=1, keepdims=True)
    observation = task.policy_observation(states)
    assert observation.shape == (4, 14) and task.policy_observation_size() == 14
    np.testing.assert_allclose(observation[:, :3], states[:, nq + 3 : nq + 6])
    for row, state in zip(observation, states, strict=True):
        inverse = state[3:7] * [1, -1, -1, -1]
        gravity, velocity = np.zeros(3), np.zeros(3)
        mujoco.mju_rotVecQuat(gravity, np.array([0.0, 0.0, -1.0]), inverse)
        mujoco.mju_rotVecQuat(velocity, state[nq : nq + 3], inverse)
        np.testing.assert_allclose(row[3:6], gravity, atol=1e-12)
        np.testing.assert_allclose(row[6:9], velocity, atol=1e-12)
    np.testing.assert_array_equal(observation[:, 9:], np.tile([0, 0, 0, 1, 0], (4, 1)))


def test_the_search_tunes_the_legs_and_waist_offsets_and_gains_only():
    problem = g1_problem()
    layout, free = problem.layout, problem.free
    assert layout.num_joints == 29 and layout.num_parameters == 29 * (20 + 9)
    assert free.sum() == g1.BALANCE_JOINTS * (1 + 9)
    observations = np.zeros((1, 14))
    observations[0, 12] = 1.0  # the constant clock
    # an offset moves only its joint; a parameter outside `free` is never touched by the search
    for joint in (0, 14):
        parameters = np.zeros((1, layout.num_parameters))
        parameters[0, joint * 20] = 0.1  # W[joint, 0, 0]
        assert free[joint * 20]
        moved = gait_actions(parameters, observations, layout)[0] - layout.home
        np.testing.assert_allclose(moved, 0.1 * (np.arange(29) == joint), atol=1e-12)
    gains = free[29 * 20 :].reshape(29, 9)
    assert gains[: g1.BALANCE_JOINTS].all() and not gains[g1.BALANCE_JOINTS :].any()  # arms held


def test_g1_episodes_start_kicked_and_the_search_runs():
    problem = g1_problem()
    drawn = np.array([problem.draw(np.random.default_rng(s)) for s in range(50)])
    speeds = np.linalg.norm(drawn[:, :2], axis=1)
    assert (speeds >= g1.KICK_SPEEDS[0]).all() and (speeds <= g1.KICK_SPEEDS[1]).all()
    assert (drawn[:, 2] == 0).all()
    episodes = GaitEpisodes(problem, workers=1)
    rows = np.zeros((2, problem.layout.num_parameters))
    kicks = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    states, sensors, ctrl = episodes.run(rows, kicks, np.zeros(2), seconds=0.1)
    episodes.close()
    nq = problem.task.model.nq
    assert abs(states[0, 0, nq]) < 0.05 and states[1, 0, nq] > 0.2  # the kick, moving on
    settings = GaitSearchSettings(
        iterations=2, population=4, elites=2, commands=2, episode_seconds=0.2, workers=1
    )
    result = search_gait(problem, settings)
    assert len(result.history) == 2 and result.parameters.shape == (problem.layout.num_parameters,)
    np.testing.assert_array_equal(result.parameters[~problem.free], problem.initial[~problem.free])
