"""distill: training pairs from real collect files, JAX training, the ONNX export on onnxruntime,
the CLI's refusals, and (slow) one teacher round on a local Ray that a rerun resumes."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
pytest.importorskip("jax")
pytest.importorskip("optax")
pytest.importorskip("onnxruntime")

from judo.collection.episode import collect_episode  # noqa: E402
from judo.core.configuration.config import shown  # noqa: E402
from judo.core.policies.onnx_policy import OnnxPolicy  # noqa: E402
from judo.core.policies.policy_controller import make_policy_controller  # noqa: E402
from judo.core.policy import PolicyError  # noqa: E402
from judo.evaluation.seeded import EpisodeSpec, configs_in_force  # noqa: E402
from judo.learning.distill import main as distill_main  # noqa: E402
from judo.learning.export import policy_metadata, write_policy  # noqa: E402
from judo.learning.pairs import read_pairs  # noqa: E402
from judo.learning.settings import TrainSettings  # noqa: E402
from judo.learning.training import train  # noqa: E402
from judo.recording.dataset import DatasetFile  # noqa: E402
from judo.recording.model_info import config_dict  # noqa: E402

SPEC = EpisodeSpec("cartpole", "ps", 1.0, values={"controller.control_freq": 20.0})
"""Short cartpole episodes, 100 steps and 20 plans each."""


def write_dataset(path: Path, spec: EpisodeSpec, seeds: range) -> Path:
    """A collect file of `spec`'s episodes for `seeds`, written as collect writes them (without
    Ray)."""
    configs = configs_in_force(spec)
    env_args = {
        "task": spec.task,
        "optimizer": spec.optimizer,
        "duration": spec.duration,
        "latency_s": 0.0,
        "plant_timestep": 0.01,
        "env_kwargs": {kind: config_dict(config) for kind, config in configs.items()},
    }
    dataset = DatasetFile(path, env_args)
    for seed in seeds:
        outcome = collect_episode(spec, seed)
        assert outcome.failure is None
        dataset.write_episode(outcome.episode)
    return path


@pytest.fixture(scope="module")
def cartpole_file(tmp_path_factory):
    return write_dataset(tmp_path_factory.mktemp("distill") / "cartpole.h5", SPEC, range(3))


def test_pairs_follow_the_steps_and_the_plans(cartpole_file):
    action = read_pairs([cartpole_file], "action")
    chunk = read_pairs([cartpole_file], "chunk")
    assert action.task == chunk.task == "cartpole" and len(action.episodes) == 3
    with h5py.File(cartpole_file, "r") as file:
        demo = file["data/demo_1"]
        qpos, qvel, actions = demo["obs/qpos"][:], demo["obs/qvel"][:], demo["actions"][:]
        knots, times = demo["plan/knots"][:], demo["plan/times"][:]
    # cartpole observes [x, cos angle, sin angle, qvel]: the state after step s gives the action of
    # step s + 1
    observed = np.column_stack([qpos[:, 0], np.cos(qpos[:, 1]), np.sin(qpos[:, 1]), qvel])
    assert observed.shape == (len(qpos), 5)
    np.testing.assert_array_equal(action.observations[1], observed[:-1])
    np.testing.assert_array_equal(action.targets[1], actions[1:])
    # each plan after the first pairs the state read at its time with its knots
    assert chunk.horizon == knots.shape[1] and len(chunk.targets[1]) == len(times) - 1 == 19
    rows = np.round(times[1:] / 0.01).astype(int) - 1
    np.testing.assert_array_equal(chunk.observations[1], observed[rows])
    np.testing.assert_array_equal(chunk.targets[1], knots[1:].reshape(19, -1))
    assert chunk.controller == {"control_freq": "20.0", "horizon": str(configs_in_force(SPEC)["controller"].horizon),  # noqa: E501
                                "spline_order": configs_in_force(SPEC)["controller"].spline_order}  # fmt: skip  # noqa: E501
    assert action.controller == {"control_freq": "100.0"}  # an action policy acts at every step


@pytest.mark.parametrize("head", ["regression", "flow"])
def test_training_lowers_the_loss_and_the_onnx_file_gives_the_jax_models_actions(
    cartpole_file, tmp_path, head
):
    pairs = read_pairs([cartpole_file], "chunk")
    trained = train(
        pairs, TrainSettings(head=head, hidden=(32, 32), epochs=40, patience=40, batch_size=32)
    )
    history = trained.history["train"]
    # the flow's has a floor
    assert history[-1] < (0.6 if head == "regression" else 0.8) * history[0], history
    assert trained.train_episodes and trained.validation_episodes
    assert not set(trained.train_episodes) & set(trained.validation_episodes)  # split by episode
    path = write_policy(
        tmp_path / "p.onnx", trained, policy_metadata(trained, pairs, "cmd", "p"), noise_scale=0.0
    )
    policy = OnnxPolicy(path)
    observations = np.concatenate(pairs.observations)[:32]
    onnx_actions = policy.act(observations).reshape(32, -1)
    np.testing.assert_allclose(onnx_actions, trained.act(observations), atol=1e-5, rtol=1e-5)
    assert policy.horizon == pairs.horizon and policy.kind == "chunk"


def test_the_flow_policy_samples_around_its_deterministic_path(cartpole_file, tmp_path):
    pairs = read_pairs([cartpole_file], "action")
    trained = train(pairs, TrainSettings(head="flow", hidden=(32,), epochs=5, batch_size=64))
    path = write_policy(
        tmp_path / "flow.onnx", trained, policy_metadata(trained, pairs, "cmd", "flow"), 1.0
    )
    policy = OnnxPolicy(path)
    observation = np.repeat(pairs.observations[0][:1], 200, axis=0)
    samples = policy.act(observation)[:, 0, 0]
    assert samples.std() > 1e-3  # noise in the graph: 200 different samples of one observation
    assert np.isfinite(samples).all() and policy.metadata["noise_scale"] == "1.0"


def test_the_metadata_round_trips_and_another_task_is_refused(cartpole_file, tmp_path):
    out = tmp_path / "policy.onnx"
    assert (
        distill_main([str(cartpole_file), "--out", str(out), "--epochs", "3", "--hidden", "16"])
        == 0
    )
    policy = OnnxPolicy(out)
    metadata = policy.metadata
    assert (metadata["task"], metadata["kind"], metadata["head"]) == (
        "cartpole",
        "action",
        "regression",
    )
    assert metadata["training_command"] == (
        f"python -m judo distill {cartpole_file} --out {out} --epochs 3 --hidden 16"
    )
    layout = (
        "(B, 5) [cart x, cos angle, sin angle, cart velocity, angular velocity] of (B, 4) states."
    )
    assert metadata["observation"] == layout and metadata["control_freq"] == "100.0"
    normalization = json.loads(metadata["normalization"])
    assert len(normalization["observation_mean"]) == 5 and len(normalization["target_std"]) == 1
    assert (tmp_path / "policy.losses.png").stat().st_size > 1000
    controller = make_policy_controller("cartpole", out)
    assert controller.config.control_freq == 100.0  # served at the rate it was trained at
    with pytest.raises(
        PolicyError,
        match=r"^policy 'policy' was made for "
        r"task 'cartpole', not 'pendulum'$",
    ):
        make_policy_controller("pendulum", out)


def refusal(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as exit_info:
        distill_main(argv)
    assert exit_info.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_bad_datasets_and_outputs_are_refused_in_one_line(cartpole_file, tmp_path, capsys):
    out = str(tmp_path / "p.onnx")
    corrupt = tmp_path / "corrupt.h5"
    corrupt.write_bytes(b"not hdf5 at all")
    assert refusal(capsys, [str(corrupt), "--out", out]).startswith(
        f"error: cannot read '{corrupt}' as an HDF5"
    )
    empty = tmp_path / "empty.h5"
    DatasetFile(empty, {"task": "cartpole"})
    assert refusal(capsys, [str(empty), "--out", out]) == (
        f"error: '{empty}' holds no episodes; run python -m judo collect into it first"
    )
    no_plans = tmp_path / "no_plans.h5"
    no_plans.write_bytes(cartpole_file.read_bytes())
    with h5py.File(no_plans, "a") as file:
        for demo in file["data"].values():
            del demo["plan/knots"]
    assert refusal(capsys, [str(no_plans), "--out", out, "--kind", "chunk"]) == (
        f"error: '{no_plans}' demo_0 has no plan/knots, which --kind chunk learns; use "
        "--kind action"
    )
    # an action policy needs no plans
    assert distill_main([str(no_plans), "--out", out, "--epochs", "1"]) == 0
    # its output (progress lines, where training takes over 5 s) is not the next refusal's
    capsys.readouterr()
    blocked = tmp_path / "a_file"
    blocked.write_text("")
    assert refusal(capsys, [str(cartpole_file), "--out", str(blocked / "p.onnx")]) == (
        f"error: --out: '{blocked}' is a file, so '{blocked}' cannot be made"
    )
    assert refusal(capsys, [str(tmp_path / "missing.h5"), "--out", out]) == (
        f"error: dataset '{tmp_path / 'missing.h5'}' does not exist; give files written by "
        "python -m judo collect"
    )
    assert refusal(capsys, [str(cartpole_file), "--out", str(tmp_path / "p.txt")]) == (
        f"error: --out must name an .onnx file, got '{tmp_path / 'p.txt'}'"
    )


def test_import_judo_does_not_import_jax():
    code = (
        "import sys, judo, judo.learning.distill; print(sorted({'jax', 'optax', 'h5py'} & "
        "set(sys.modules)))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "[]"


@pytest.mark.slow
def test_a_teacher_round_on_a_local_ray_writes_its_files_and_a_rerun_resumes(
    cartpole_file, tmp_path, capsys
):
    out = tmp_path / "taught.onnx"
    argv = [str(cartpole_file), "--out", str(out), "--rounds", "1", "--episodes-per-round", "2"]
    argv += ["--eval-seeds", "1", "--workers", "2", "--epochs", "3", "--hidden", "16"]
    assert distill_main(argv) == 0
    folder = tmp_path / "taught_rounds"
    assert sorted(path.name for path in folder.iterdir()) == [
        "distill_run.json", "policy_round_0.losses.png", "policy_round_0.onnx", "policy_round_1.losses.png", "policy_round_1.onnx",  # noqa: E501
        "round_1.h5",
    ]  # fmt: skip
    with h5py.File(folder / "round_1.h5", "r") as file:
        assert sorted(file["data"]) == ["demo_100000", "demo_100001"]  # the round's own seeds
        assert "mpc_actions" in file["data/demo_100000"]  # the policy drove, the MPC labelled
    shipped, last_round = OnnxPolicy(out), OnnxPolicy(folder / "policy_round_1.onnx")
    assert shipped.metadata["name"] == "taught" and last_round.metadata["name"] == "policy_round_1"
    assert {k: v for k, v in shipped.metadata.items() if k != "name"} == {
        k: v for k, v in last_round.metadata.items() if k != "name"
    }  # round 1's policy, named after its file
    observations = np.random.default_rng(0).normal(size=(5, shipped.observation_size))
    np.testing.assert_array_equal(shipped.act(observations), last_round.act(observations))
    first = capsys.readouterr().out
    assert "teacher rounds" in first and "policy alone" in first
    assert distill_main(argv) == 0
    again = capsys.readouterr().out
    assert "round 1: " + str(folder / "policy_round_1.onnx") + " exists; resumed" in again
    other = [*argv[:-2], "--hidden", "8"]  # the same run but for the width: refused, not "resumed"
    assert refusal(capsys, other) == (
        f"error: '{folder}' holds teacher rounds of --hidden 16, not --hidden 8; rerun with "
        "those to resume them, "
        "or give another --out to start new rounds"
    )


@pytest.mark.parametrize(
    ("eval_seeds", "title"), [(3, "measured on seeds 10000-10002"), (0, "not measured")]
)
def test_the_round_table_names_the_seeds_it_was_measured_on_or_says_it_was_not(eval_seeds, title):
    from rich.console import Console

    from judo.learning.args import DistillArgs
    from judo.learning.rounds import round_table

    args = DistillArgs(
        datasets=(Path("d.h5"),), out=Path("p.onnx"), eval_seeds=eval_seeds, eval_first_seed=10000
    )
    console = Console(record=True, width=200)
    console.print(round_table([["0", "10", "100", "1.0", "-", "-"]], args, {"task": "pendulum"}))
    text = " ".join(console.export_text().split())  # the title wraps at the table's width
    assert f"teacher rounds, {title}" in text and "10000-9999" not in text


def test_an_existing_out_is_refused_without_overwrite_and_replaced_with_it(
    cartpole_file, tmp_path, capsys
):
    out = tmp_path / "p.onnx"
    out.write_bytes(b"an earlier policy")
    assert refusal(capsys, [str(cartpole_file), "--out", str(out), "--epochs", "1"]) == (
        f"error: --out '{out}' exists; give --overwrite to replace it, or another --out"
    )
    assert out.read_bytes() == b"an earlier policy"
    assert (
        distill_main([str(cartpole_file), "--out", str(out), "--epochs", "1", "--overwrite"]) == 0
    )
    assert OnnxPolicy(out).metadata["task"] == "cartpole"


def test_teacher_settings_and_names_are_refused_before_any_training(
    cartpole_file, tmp_path, capsys
):
    out = tmp_path / "p.onnx"
    assert refusal(capsys, [str(cartpole_file), "--out", str(out), "--proposals", "4"]) == (
        "error: --proposals 4 samples candidates in the teacher rounds; give --rounds 1 or "
        "more with it"
    )
    assert refusal(
        capsys, [str(cartpole_file), "--out", str(out), "--rounds", "1", "--proposals", "1000"]
    ) == (
        "error: --proposals 1000 must be below the teacher's num_rollouts (64, ps on "
        "cartpole): the nominal, "
        "rollout 0, is never replaced; expected 0 to 63"
    )
    # the name fits, its "_rounds" folder and loss PNG do not
    long_out = tmp_path / ("p" * 250 + ".onnx")
    assert refusal(capsys, [str(cartpole_file), "--out", str(long_out)]) == (
        f"error: --out: the name {shown('p' * 250 + '.losses.png')} is 261 bytes long; the "
        "file system allows at most 255; "
        "give a shorter name"
    )
    long_folder = tmp_path / ("f" * 300) / "p.onnx"  # a folder to make whose name is too long
    assert refusal(capsys, [str(cartpole_file), "--out", str(long_folder)]) == (
        f"error: --out: the name {shown('f' * 300)} is 300 bytes long; the file system "
        "allows at most 255; "
        "give a shorter name"
    )
    assert not out.exists() and not any(tmp_path.iterdir())  # nothing trained, nothing written


def test_a_resume_with_other_training_settings_is_refused_in_one_line(
    cartpole_file, tmp_path, capsys
):
    from judo.learning.args import DistillArgs
    from judo.learning.rounds import RUN_RECORD

    out = tmp_path / "taught.onnx"
    first = [
        "--out",
        str(out),
        "--rounds",
        "1",
        "--kind",
        "action",
        "--hidden",
        "16",
        "16",
        "--epochs",
        "3",
    ]
    folder = tmp_path / "taught_rounds"
    folder.mkdir()
    (folder / "policy_round_0.onnx").write_bytes(b"round 0 of a run with no record")
    assert refusal(capsys, [str(cartpole_file), *first]) == (
        f"error: '{folder}' holds teacher rounds whose settings were not recorded, so they "
        "cannot be resumed; "
        "remove it, or give another --out"
    )
    earlier = DistillArgs(
        datasets=(cartpole_file,), out=out, rounds=1, kind="action", hidden=(16, 16), epochs=3
    )
    (folder / RUN_RECORD).write_text(json.dumps(earlier.run_record()))  # as the first run writes it
    again = [
        str(cartpole_file),
        "--out",
        str(out),
        "--rounds",
        "2",
        "--kind",
        "chunk",
        "--hidden",
        "8",
    ]
    assert refusal(capsys, [*again, "--epochs", "3"]) == (
        f"error: '{folder}' holds teacher rounds of --hidden 16 16 --kind action, not "
        "--hidden 8 --kind chunk; "
        "rerun with those to resume them, or give another --out to start new rounds"
    )
    # untouched
    assert sorted(path.name for path in folder.iterdir()) == [RUN_RECORD, "policy_round_0.onnx"]


def test_a_low_level_task_is_refused_before_training(tmp_path, capsys):
    spec = EpisodeSpec("quadruped_navigate", "ps", 0.04, values={"optimizer.num_rollouts": 4})
    # 4 control updates of 3 commands each
    path = write_dataset(tmp_path / "quadruped.h5", spec, range(1))
    for kind in ("action", "chunk"):
        assert refusal(capsys, [str(path), "--out", str(tmp_path / "p.onnx"), "--kind", kind]) == (
            "error: distill cannot learn task 'quadruped_navigate': its MPC plans 3 commands "
            "for a low-level policy "
            "that drives the 12 actuators, while a distilled policy is served to the "
            "actuators; give datasets of a "
            "task without a low-level policy"
        )
