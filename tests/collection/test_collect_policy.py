"""Policy-served collection (`collect --policy FILE.onnx --optimizer O`): the policy drives the
plant, the MPC plans from every state it visits, and the file keeps the MPC's plans and actions as
labels beside the served actions. Real ONNX files on onnxruntime; the episode in-process (as its Ray
task runs it), the command on a local Ray."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from judo.collection.collect import main as collect_main
from judo.collection.episode import collect_episode
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.recording.dataset import DatasetFile

h5py = pytest.importorskip("h5py")
pytest.importorskip("onnxruntime")
from judo.core.policies.onnx_policy import write_linear_policy  # noqa: E402

DOC = (Path(__file__).resolve().parents[2] / "docs" / "collect.md").read_text()
CONSTANT = 0.25
"""The policy's action: a constant push (exact in float32), far from what the MPC plans."""


@pytest.fixture
def push_policy(tmp_path):
    return write_linear_policy(
        tmp_path / "push.onnx", np.zeros((1, 5)), [CONSTANT], metadata={"task": "cartpole"}
    )


def test_the_file_holds_the_served_actions_and_the_mpcs_plans_and_actions_as_labels(
    push_policy, tmp_path
):
    spec = EpisodeSpec(
        "cartpole", "ps", 0.3, policy=str(push_policy), values={"controller.control_freq": 20.0}
    )
    outcome = collect_episode(spec, seed=0)
    assert outcome.failure is None
    episode = outcome.episode
    DatasetFile(tmp_path / "labels.h5", {"task": "cartpole"}).write_episode(episode)
    with h5py.File(tmp_path / "labels.h5", "r") as file:
        demo = file["data/demo_0"]
        actions, labels = demo["actions"][:], demo["mpc_actions"][:]
        knots, times = demo["plan/knots"][:], demo["plan/times"][:]
        chunks, inference = demo["policy/knots"][:], demo["policy/inference_ms"][:]
        step_times = demo["obs/qpos"].shape[0]
    assert np.all(actions == CONSTANT)  # the policy drove
    documented = dict(
        re.findall(
            r"^\| `data/demo_<seed>/((?:mpc_actions|policy/)[^`]*)` "
            r"\| (\([^)]*\))",
            DOC,
            re.M,
        )
    )
    assert documented == {
        "mpc_actions": "(S, nu)",
        "policy/knots": "(U, H, nu)",
        "policy/inference_ms": "(U,)",
    }
    # 20 Hz x 0.3 s, the MPC's knots
    assert len(times) == 6 and knots.shape[0] == 6 and knots.shape[2] == 1
    assert chunks.shape == (6, 1, 1) and np.all(chunks == CONSTANT) and np.all(inference > 0)
    assert labels.shape == actions.shape == (step_times, 1) and np.isfinite(labels).all()
    # the MPC's own actions, from the states the policy visited
    assert not np.allclose(labels, CONSTANT)
    steps_per_plan = step_times // len(times)
    # each plan at its start
    np.testing.assert_allclose(labels[::steps_per_plan, 0], knots[:, 0, 0], atol=1e-12)


def test_the_episode_is_the_same_with_the_mpc_labelling_or_not(push_policy):
    """The MPC never touches the plant: the served actions and states equal those of the policy
    alone."""
    alone = run_seeded_episode(
        EpisodeSpec("cartpole", None, 0.2, policy=str(push_policy)), seed=3
    ).log
    labelled = collect_episode(
        EpisodeSpec("cartpole", "ps", 0.2, policy=str(push_policy)), seed=3
    ).episode
    np.testing.assert_array_equal(
        alone.states, np.concatenate([labelled.qpos, labelled.qvel], axis=1)
    )
    np.testing.assert_array_equal(alone.controls, labelled.actions)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            [],
            "collect --policy needs --optimizer NAME: the MPC that plans from the "
            "states the policy visits, for the labels",
        ),
        (
            ["--optimizer", "ps", "--latency", "measured"],
            "collect --policy with --latency measured would count the MPC's "
            "labelling in the policy's latency; give --latency-ms MS",
        ),
        (
            ["--optimizer", "ps", "--task", "acrobot"],
            "policy 'push' was made for task 'cartpole', not 'acrobot'",
        ),
    ],
)
def test_bad_policy_arguments_are_one_line_and_exit_2(
    push_policy, tmp_path, capsys, extra, message
):
    with pytest.raises(SystemExit) as exit_info:
        collect_main(
            [
                "--task",
                "cartpole",
                "--policy",
                str(push_policy),
                *extra,
                "--out",
                str(tmp_path / "x.h5"),
            ]
        )
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == f"error: {message}\n"


@pytest.mark.slow
def test_collect_policy_writes_labels_and_resumes_only_with_the_same_policy(
    local_ray, push_policy, tmp_path, capsys
):
    out = tmp_path / "served.h5"
    argv = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--policy",
        str(push_policy),
        "--duration",
        "0.2",
    ]
    assert collect_main([*argv, "--episodes", "2", "--workers", "2", "--out", str(out)]) == 0
    with h5py.File(out, "r") as file:
        assert sorted(file["data"]) == ["demo_0", "demo_1"]
        assert file["data/demo_1/mpc_actions"].shape == file["data/demo_1/actions"].shape
        policy = json.loads(file["data"].attrs["env_args"])["policy"]
    assert (
        policy["name"] == "push"
        and policy["metadata"]["task"] == "cartpole"
        and len(policy["sha256"]) == 64
    )
    other = write_linear_policy(
        tmp_path / "push.onnx", np.zeros((1, 5)), [0.1], metadata={"task": "cartpole"}
    )
    with pytest.raises(SystemExit):
        collect_main(
            [
                *argv[:-2],
                "--policy",
                str(other),
                "--duration",
                "0.2",
                "--episodes",
                "3",
                "--out",
                str(out),
            ]
        )
    assert "policy.sha256: file has" in capsys.readouterr().err


def test_collect_with_a_nan_policy_says_so_loudly_and_strict_exits_1(local_ray, tmp_path, capsys):
    nan = write_linear_policy(
        tmp_path / "nan.onnx", np.full((1, 5), np.nan), metadata={"task": "cartpole"}
    )
    argv = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--policy",
        str(nan),
        "--duration",
        "0.2",
        "--episodes",
        "1",
    ]
    argv += ["--workers", "1", "--controller.max-plan-age", "0.1"]
    assert collect_main([*argv, "--out", str(tmp_path / "a.h5")]) == 0
    told = [
        line for line in capsys.readouterr().err.splitlines() if not line.startswith("collect done")
    ]
    # the progress line shows up too where the episode took 5 s or more
    assert "\n".join(told).strip() == (
        "warning: in 1 of 1 episodes every control update gave non-finite actions, so every "
        "action stored is the "
        "task's safe action, not a plan's; --strict makes this exit 1"
    )
    assert collect_main([*argv, "--out", str(tmp_path / "b.h5"), "--strict"]) == 1
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "--strict: 1 of 1 episodes had failed control updates"
    )
