"""`evaluate --proposal-policy FILE.onnx` with `--controller.policy-samples K` (or the field in a
--config file)."""

import json

import numpy as np
import pytest

from judo.evaluation.evaluate import main

pytest.importorskip("onnxruntime")
TINY = [
    "--task",
    "cartpole",
    "--optimizer",
    "ps",
    "--seeds",
    "1",
    "--duration",
    "0.3",
    "--num-workers",
    "1",
]


@pytest.fixture
def policy_file(tmp_path):
    from judo.core.policies.onnx_policy import write_linear_policy

    # any linear law on the observation: proposals can only help
    weight = np.array([[1.0, 0.0, -2.0, 0.5, -0.5]])
    return write_linear_policy(tmp_path / "law.onnx", weight, metadata={"task": "cartpole"})


def test_evaluate_plans_with_the_policy_s_proposals(tmp_path, policy_file):
    path = tmp_path / "report.json"
    argv = [
        *TINY,
        "--controller.policy-samples",
        "4",
        "--proposal-policy",
        str(policy_file),
        "--json",
        str(path),
    ]
    assert main(argv) == 0
    report = json.loads(path.read_text())
    assert report["controller"] == {"policy_samples": 4}
    assert report["proposal_policy"] == str(policy_file)
    assert np.isfinite(report["summary"]["mean_reward"]["mean"])


def test_policy_samples_from_a_config_file(tmp_path, policy_file):
    config = tmp_path / "proposals.toml"
    config.write_text("[controller_config_overrides.cartpole]\npolicy_samples = 3\n")
    path = tmp_path / "report.json"
    assert (
        main(
            [
                *TINY,
                "--config",
                str(config),
                "--proposal-policy",
                str(policy_file),
                "--json",
                str(path),
            ]
        )
        == 0
    )
    assert json.loads(path.read_text())["episodes"][0]["failed_updates"] == 0


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--controller.policy-samples", "4"],
            "error: policy_samples is 4 but the controller has no proposal policy; "
            "give one (make_controller(..., "
            "proposal_policy=...), evaluate --proposal-policy FILE.onnx) or set it to 0",
        ),
        (
            ["--proposal-policy", "{policy}"],
            "error: --proposal-policy {policy} is given but policy_samples is 0, so "
            "it would never be used; set "
            "--controller.policy-samples K (1 to num_rollouts - 1)",
        ),
        (
            [
                "--controller.policy-samples",
                "4",
                "--proposal-policy",
                "{policy}",
                "--task",
                "acrobot",
            ],
            "error: policy 'law' was made for task 'cartpole', not 'acrobot'",
        ),
        (
            [
                "--controller.policy-samples",
                "4",
                "--proposal-policy",
                "{policy}",
                "--policy",
                "{policy}",
            ],
            "error: --proposal-policy proposes candidates to an optimizer's plan, "
            "but --policy drives the plant "
            "itself; give one",
        ),
    ],
    ids=["no-policy", "no-samples", "another-task", "with-policy"],
)
def test_one_line_errors(policy_file, capsys, extra, message):
    with pytest.raises(SystemExit) as exit_info:
        main([*TINY, *(arg.format(policy=policy_file) for arg in extra)])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip() == message.format(policy=policy_file)


def test_a_failing_proposal_policy_is_told_in_one_clean_warning_line(tmp_path):
    import subprocess
    import sys

    from judo.core.policies.onnx_policy import write_linear_policy

    nan = write_linear_policy(
        tmp_path / "nan.onnx", np.full((1, 5), np.nan), metadata={"task": "cartpole"}
    )
    argv = [
        *TINY,
        "--duration",
        "0.1",
        "--controller.policy-samples",
        "2",
        "--proposal-policy",
        str(nan),
    ]
    result = subprocess.run(
        [sys.executable, "-m", "judo", "evaluate", *argv],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines and all(
        line.startswith("warning: this update runs without proposals: ") for line in lines
    ), lines
    assert ".py:" not in result.stderr  # no file path and line, no source line
