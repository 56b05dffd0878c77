"""gait-search on the Go2: its layout phases the trot's diagonal pairs in Unitree's motor order, its
observation is go2_walk's, its episodes are real Go2 physics scored by go2_walk's reward, and the
command writes the same policy as ONNX and as the JSON file GaitPolicy runs in numpy."""

import numpy as np
import pytest

from judo.learning.gait_search import main as gait_search_main
from judo.learning.policy_search import (
    GO2_COMMAND_RANGE,
    GaitEpisodes,
    GaitSearchSettings,
    go2_problem,
    search_gait,
    stepping_in_place,
)
from judo.tasks.gait import GAITS, gait_clock, swing_heights
from judo.tasks.gait_policy import GaitPolicy, gait_actions
from judo.tasks.unitree.go2 import FALLEN_HEIGHT, POSTURE, RISE_POSE, Go2Walk


def test_the_go2_layout_trots_fr_rl_against_fl_rr_around_the_rise_pose():
    problem = go2_problem()
    layout = problem.layout
    assert problem.name == "go2_walk" and layout.observation_size == 35 == layout.num_joints + 23
    np.testing.assert_array_equal(layout.home, RISE_POSE)
    # motors FR, FL, RR, RL x hip, thigh, calf: FR and RL together, FL and RR half a cycle after
    np.testing.assert_array_equal(layout.phase_signs.reshape(4, 3)[:, 0], [1, -1, -1, 1])
    assert layout.num_parameters == 12 * (5 * 4 + 6)
    times = np.linspace(0.0, 0.4, 41)  # one trot cycle
    observations = np.zeros((len(times), 35))
    observations[:, 33:35] = gait_clock(times)
    targets = gait_actions(np.tile(stepping_in_place(layout), (41, 1)), observations, layout)
    calf_fold = RISE_POSE[2::3] - targets[:, 2::3]  # (time, leg), > 0 where the calf folds
    heights = swing_heights(times, GAITS["trot"], 0.06)  # go2_walk's foot schedule
    assert (calf_fold[heights > 0.05] > 0.4).all()
    assert (np.abs(calf_fold[heights == 0]) < 0.06).all()


def test_the_go2_observation_is_proprioception_the_command_and_the_clock():
    task = Go2Walk(policy_path=None)
    task.config.velocity_command = np.array([0.4, -0.1, 0.2])
    rng = np.random.default_rng(0)
    states = np.zeros((3, task.model.nq + task.model.nv))
    states[:, 3] = 1.0  # level
    states[:, 7:19] = POSTURE + rng.normal(0, 0.1, (3, 12))
    states[:, 19:] = rng.normal(0, 1.0, (3, 18))
    sensors = np.zeros((3, task.model.nsensordata))
    sensors[:, task._clock] = [0.0, 0.1, 0.25]
    observation = task.policy_observation(states, sensors)
    assert observation.shape == (3, 35) and task.policy_observation_size() == 35
    np.testing.assert_allclose(observation[:, :12], states[:, 7:19] - POSTURE)
    np.testing.assert_allclose(observation[:, 12:24], states[:, 25:37])  # joint speeds
    np.testing.assert_allclose(observation[:, 24:27], states[:, 22:25])  # gyro, base frame
    np.testing.assert_allclose(observation[:, 27:30], np.tile([0, 0, -1.0], (3, 1)), atol=1e-12)
    np.testing.assert_allclose(observation[:, 30:33], np.tile([0.4, -0.1, 0.2], (3, 1)))
    np.testing.assert_allclose(observation[:, 33:35], gait_clock(np.array([0.0, 0.1, 0.25])))


def test_go2_episodes_are_real_physics_and_the_rise_pose_stands():
    problem = go2_problem()
    episodes = GaitEpisodes(problem, workers=1)
    standing = np.zeros((2, problem.layout.num_parameters))  # all zero: RISE_POSE's targets
    commands = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    states, sensors, ctrl = episodes.run(standing, commands, np.zeros(2), seconds=1.0)
    episodes.close()
    assert states.shape == (2, 50, 37) and ctrl.shape == (2, 50, 12)
    np.testing.assert_allclose(ctrl, np.broadcast_to(RISE_POSE, ctrl.shape))
    assert (states[:, -10:, 2] > 0.28).all() and (states[:, :, 2] > FALLEN_HEIGHT).all()
    asked = [problem.reward(states[i : i + 1], sensors[i : i + 1], ctrl[i : i + 1], c) for i, c in
             enumerate(commands)]  # fmt: skip
    assert asked[1][0] < asked[0][0]  # standing is worse when 0.5 m/s is asked for
    drawn = np.array([problem.draw(np.random.default_rng(s)) for s in range(50)])
    assert (drawn >= GO2_COMMAND_RANGE[:, 0]).all() and (drawn <= GO2_COMMAND_RANGE[:, 1]).all()


def test_a_short_go2_search_runs():
    settings = GaitSearchSettings(
        iterations=2, population=4, elites=2, commands=2, episode_seconds=0.2, workers=1
    )
    result = search_gait(go2_problem(), settings)
    assert result.parameters.shape == (312,) and len(result.history) == 2
    assert all(np.isfinite(r.mean_reward) for r in result.history)


def test_the_command_writes_the_go2_policy_as_onnx_and_as_json_alike(tmp_path):
    pytest.importorskip("onnxruntime")
    from judo.core.policies.onnx_policy import OnnxPolicy

    out = tmp_path / "go2.onnx"
    argv = ["--task", "go2_walk", "--out", str(out), "--iterations", "1", "--population", "2"]
    argv += ["--elites", "1", "--commands", "1", "--episode-seconds", "0.1", "--workers", "1"]
    assert gait_search_main(argv) == 0
    onnx_policy, json_policy = OnnxPolicy(out), GaitPolicy.load(tmp_path / "go2.json")
    assert onnx_policy.metadata["task"] == json_policy.metadata["task"] == "go2_walk"
    observations = np.random.default_rng(0).normal(0.0, 0.5, (8, 35))
    observations[:, 33:35] = gait_clock(np.linspace(0, 0.4, 8))
    np.testing.assert_allclose(
        onnx_policy.act(observations), json_policy.act(observations), atol=1e-5
    )


def test_gait_policy_gives_gait_actions_targets_and_reads_back_from_json(tmp_path):
    from judo.tasks.gait_policy import save_gait_policy

    layout = go2_problem().layout
    rng = np.random.default_rng(3)
    parameters = rng.normal(0.0, 0.1, layout.num_parameters)
    observations = rng.normal(0.0, 1.0, (9, 35))
    observations[:, 33:35] = gait_clock(rng.uniform(0, 1, 9))
    expected = gait_actions(np.tile(parameters, (9, 1)), observations, layout)
    path = save_gait_policy(tmp_path / "p.json", parameters, layout, {"task": "go2_walk"})
    for policy in (GaitPolicy(parameters, layout), GaitPolicy.load(path)):
        assert (policy.observation_size, policy.action_size, policy.horizon) == (35, 12, 1)
        np.testing.assert_allclose(policy.act(observations)[:, 0], expected, atol=1e-12)
    assert GaitPolicy.load(path).metadata == {"task": "go2_walk", "name": "p"}
