"""`python -m judo evaluate --policy FILE.onnx`: the same metrics as for an optimizer, the inference
time where an optimizer's update time is printed, and one-line errors (exit 2) for a policy that
does not fit the task. Real ONNX files written with the onnx helper API, run on onnxruntime."""

import json

import numpy as np
import pytest

from judo.evaluation.evaluate import main

pytest.importorskip("onnxruntime")
from judo.core.policies.onnx_policy import write_linear_policy

TINY = ["--task", "cartpole", "--seeds", "2", "--duration", "0.4", "--num-workers", "1"]


@pytest.fixture
def cartpole_policy(tmp_path):
    """a = -0.5 x - 2 sin theta - 0.1 xdot - 0.2 thetadot on [x, cos, sin, xdot, thetadot], for
    cartpole, at 25 Hz."""
    metadata = {"task": "cartpole", "control_freq": "25"}
    return write_linear_policy(
        tmp_path / "pd.onnx", np.array([[-0.5, 0.0, -2.0, -0.1, -0.2]]), metadata=metadata
    )


def test_a_policy_prints_the_optimizers_metrics_and_its_inference_time(
    cartpole_policy, tmp_path, capsys
):
    path = tmp_path / "policy.json"
    assert main([*TINY, "--policy", str(cartpole_policy), "--json", str(path)]) == 0
    out = " ".join(capsys.readouterr().out.split())  # the table wraps its caption
    assert "cartpole x policy pd: 2 seeds x 0.4 s" in out
    # 25 Hz x 0.4 s x 2
    assert "policy inference: median" in out and "µs per update over 20 updates" in out
    report = json.loads(path.read_text())
    assert report["policy"] == str(cartpole_policy.resolve()) and report["optimizer"] is None
    assert [episode["num_updates"] for episode in report["episodes"]] == [10, 10]
    assert (
        main(
            [
                "--task",
                "cartpole",
                "--optimizer",
                "ps",
                *TINY[2:],
                "--json",
                str(tmp_path / "ps.json"),
            ]
        )
        == 0
    )
    ps = json.loads((tmp_path / "ps.json").read_text())
    assert set(ps["summary"]) == set(report["summary"])  # the same metrics, mean_reward among them


def test_the_command_line_wins_over_the_policys_metadata(cartpole_policy, tmp_path, capsys):
    path = tmp_path / "policy.json"
    argv = [
        *TINY,
        "--seeds",
        "1",
        "--policy",
        str(cartpole_policy),
        "--controller.control-freq",
        "10",
    ]
    assert main([*argv, "--json", str(path)]) == 0
    assert json.loads(path.read_text())["episodes"][0]["num_updates"] == 4


@pytest.mark.parametrize(
    ("weight", "metadata", "message"),
    [
        (
            np.zeros((1, 5)),
            {"task": "acrobot"},
            "policy 'bad' was made for task 'acrobot', not 'cartpole'",
        ),
        (
            np.zeros((1, 3)),
            {},
            "policy 'bad' takes observations of size 3, but the task cartpole gives 5",
        ),
        (
            np.zeros((2, 5)),
            {},
            "policy 'bad' gives actions of size 2, but the task cartpole needs 1",
        ),
    ],
)
def test_a_policy_that_does_not_fit_the_task_is_one_line_and_exit_2(
    tmp_path, capsys, weight, metadata, message
):
    bad = write_linear_policy(tmp_path / "bad.onnx", weight, metadata=metadata)
    with pytest.raises(SystemExit) as exit_info:
        main([*TINY, "--policy", str(bad)])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == f"error: {message}\n"


def test_neither_optimizer_nor_policy_and_a_missing_file_are_one_line_and_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(TINY)
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == (
        "error: give --optimizer NAME (or --policy FILE.onnx to run a policy)\n"
    )
    with pytest.raises(SystemExit) as exit_info:
        main([*TINY, "--policy", str(tmp_path / "none.onnx")])
    assert exit_info.value.code == 2
    assert "does not exist; expected an .onnx file" in capsys.readouterr().err


def test_a_policy_that_returns_nan_fails_every_update_and_evaluate_says_so(tmp_path, capsys):
    nan = write_linear_policy(
        tmp_path / "nan.onnx", np.full((1, 5), np.nan), metadata={"task": "cartpole"}
    )
    assert (
        main([*TINY, "--seeds", "1", "--policy", str(nan), "--controller.max-plan-age", "0.1"]) == 0
    )
    printed = capsys.readouterr()
    out = " ".join(printed.out.split())
    assert (
        "mean_reward" in out
        and "seed 0: 0 simulation divergences, 20 updates with non-finite actions" in out
    )
    assert printed.err.strip() == (
        "warning: seed 0: every one of its 20 control updates gave non-finite actions, so "
        "every action served was "
        "the task's safe action; these figures measure the safe action, not the policy"
    )
    strict = [
        *TINY,
        "--seeds",
        "1",
        "--policy",
        str(nan),
        "--controller.max-plan-age",
        "0.1",
        "--strict",
    ]
    assert main(strict) == 1
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "--strict: 1 of 1 episodes had failed control updates or simulation divergences"
    )
