"""gait-search: the gait policy's ONNX graph gives gait_actions' targets, the search's episodes are
real quadruped physics scored by quadruped_velocity's reward, and the command writes a policy
OnnxPolicy serves."""

import json

import numpy as np
import pytest

from judo.core.policies.onnx_policy import OnnxPolicy
from judo.learning.gait_policy import gait_policy_model
from judo.learning.gait_search import main as gait_search_main
from judo.learning.policy_search import (
    GaitEpisodes,
    GaitSearchSettings,
    quadruped_gait_layout,
    quadruped_problem,
    search_gait,
    stepping_in_place,
)
from judo.tasks.gait import GAITS, gait_clock, swing_heights
from judo.tasks.gait_policy import gait_actions, phase_features
from judo.tasks.quadruped import STANDING_HEIGHT
from judo.tasks.quadruped_velocity import COMMAND_KEY, QuadrupedVelocity

pytest.importorskip("onnxruntime")


def test_the_phase_features_are_the_clock_s_harmonics():
    times = np.array([0.0, 0.1, 0.13, 0.37])
    phase = 2 * np.pi * GAITS["trot"].frequency * times
    expected = np.stack(
        [np.ones(4), np.cos(phase), np.sin(phase), np.cos(2 * phase), np.sin(2 * phase)], axis=1
    )
    np.testing.assert_allclose(phase_features(gait_clock(times)), expected, atol=1e-12)


def test_the_onnx_graph_gives_gait_actions_targets(tmp_path):
    task = QuadrupedVelocity()
    layout = quadruped_gait_layout(task)
    rng = np.random.default_rng(0)
    parameters = rng.normal(0.0, 0.1, layout.num_parameters)
    observations = rng.normal(0.0, 1.0, (16, 35))
    observations[:, 33:35] = gait_clock(rng.uniform(0, 1, 16))
    path = tmp_path / "gait.onnx"
    path.write_bytes(
        gait_policy_model(parameters, layout, {"task": "quadruped_velocity"}).SerializeToString()
    )
    policy = OnnxPolicy(path)
    assert (policy.observation_size, policy.action_size, policy.horizon) == (35, 12, 1)
    expected = gait_actions(np.tile(parameters, (16, 1)), observations, layout)
    np.testing.assert_allclose(policy.act(observations)[:, 0], expected, atol=1e-5)


def test_the_diagonal_legs_swing_half_a_cycle_apart_and_the_first_mean_lifts_each_foot_in_its_swing():  # noqa: E501
    task = QuadrupedVelocity()
    layout = quadruped_gait_layout(task)
    # FR, FL, RR, RL
    np.testing.assert_array_equal(layout.phase_signs.reshape(4, 3)[:, 0], [1, -1, -1, 1])
    times = np.linspace(0.0, 0.4, 41)  # one trot cycle
    observations = np.zeros((len(times), 35))
    observations[:, 33:35] = gait_clock(times)
    targets = gait_actions(
        np.tile(stepping_in_place(layout), (len(times), 1)), observations, layout
    )
    # (time, leg): > 0 where the knee folds further
    knee_bend = task.home_ctrl[2::3] - targets[:, 2::3]
    heights = swing_heights(times, GAITS["trot"], 0.07)  # (time, leg) the reward's foot schedule
    assert (knee_bend[heights > 0.06] > 0.4).all()  # mid-swing: folded by about 0.5 rad
    assert (np.abs(knee_bend[heights == 0.0]) < 0.06).all()  # standing: about the standing pose


def test_the_episodes_are_real_physics_and_a_standing_policy_stands():
    problem = quadruped_problem()
    task, layout = problem.task, problem.layout
    episodes = GaitEpisodes(problem, workers=2)
    standing = np.zeros((2, layout.num_parameters))  # all zero: the standing pose's targets
    commands = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    states, sensors, ctrl = episodes.run(standing, commands, np.zeros(2), seconds=1.0)
    episodes.close()
    assert states.shape == (2, 50, 37) and ctrl.shape == (2, 50, 12)
    np.testing.assert_allclose(ctrl, np.broadcast_to(task.home_ctrl, ctrl.shape))
    assert (states[:, :, 2] > 0.9 * STANDING_HEIGHT).all()  # stands
    assert np.abs(states[:, -1, :2]).max() < 0.02  # and goes nowhere
    # each tick keeps its last step's row: the clock sensor reads that step's start (sensors come
    # before the step)
    np.testing.assert_allclose(
        sensors[0, :, task._clock], 0.02 * np.arange(1, 51) - 0.01, atol=1e-9
    )
    asked = [
        task.reward(
            states[i : i + 1], sensors[i : i + 1], ctrl[i : i + 1], task.config, {COMMAND_KEY: c}
        )
        for i, c in enumerate(commands)
    ]
    assert asked[1][0] < asked[0][0]  # standing is worse when 0.5 m/s is asked for


def test_a_short_search_runs_the_cem_and_keeps_every_iteration():
    settings = GaitSearchSettings(
        iterations=2, population=4, elites=2, commands=2, episode_seconds=0.2, workers=1
    )
    seen = []
    result = search_gait(quadruped_problem(), settings, seen.append)
    history = result.history
    layout = quadruped_gait_layout(QuadrupedVelocity())
    assert result.parameters.shape == (layout.num_parameters,) and [r.index for r in history] == [
        0,
        1,
    ]
    assert seen == history and not result.interrupted
    assert all(
        np.isfinite([r.mean_reward, r.best_reward]).all() and r.best_reward >= r.mean_reward
        for r in history
    )
    rewards = [r.mean_reward for r in history]
    # the best iteration's mean, not the last one
    assert result.best_index == int(np.argmax(rewards))
    first_mean = stepping_in_place(layout)
    # iteration 0 scores the start
    assert np.allclose(result.parameters, first_mean) == (result.best_index == 0)


def test_ctrl_c_ends_the_search_with_the_best_so_far():
    settings = GaitSearchSettings(
        iterations=5, population=2, elites=1, commands=1, episode_seconds=0.1, workers=1
    )

    def interrupt_at(index):
        def on_iteration(record):
            if record.index == index:
                raise KeyboardInterrupt  # what Ctrl-C raises in the main thread

        return on_iteration

    result = search_gait(quadruped_problem(), settings, interrupt_at(1))
    assert result.interrupted and [r.index for r in result.history] == [0, 1]
    assert result.best_index == int(np.argmax([r.mean_reward for r in result.history]))
    first_only = search_gait(quadruped_problem(), settings, interrupt_at(0))
    assert first_only.interrupted and first_only.best_index == 0 and len(first_only.history) == 1


def test_the_command_writes_a_policy_that_names_its_task_and_command(tmp_path, capsys):
    out = tmp_path / "gait.onnx"
    argv = [
        "--out",
        str(out),
        "--iterations",
        "1",
        "--population",
        "2",
        "--elites",
        "1",
        "--commands",
        "1",
    ]
    assert gait_search_main([*argv, "--episode-seconds", "0.1", "--workers", "1"]) == 0
    policy = OnnxPolicy(out)
    assert (
        policy.metadata["task"] == "quadruped_velocity"
        and policy.metadata["control_freq"] == "50.0"
    )
    assert policy.metadata["training_command"].startswith("python -m judo gait-search --out")
    printed = capsys.readouterr().out
    assert (
        "score it on fresh seeds" in printed and "the mean of iteration 1, the best of 1" in printed
    )
    assert json.loads(policy.metadata["search"])["best_iteration"] == 1
    with pytest.raises(SystemExit) as exit_info:  # the policy is not overwritten without a word
        gait_search_main([*argv, "--episode-seconds", "0.1", "--workers", "1"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip() == (
        f"error: --out '{out}' exists; give --overwrite to replace it, or another --out"
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--out", "x.onnx", "--elites", "100"], "--elites"),
        (["--out", "x.txt"], "--out must name an .onnx file"),
        (["--out", "x.onnx", "--sigma-min", "0.5", "--sigma-max", "0.1"], "--sigma-min"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        gait_search_main(argv)
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1
