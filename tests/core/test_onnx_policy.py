"""OnnxPolicy on real onnxruntime, with ONNX files written here by judo's own writers (the onnx
helper API)."""

import sys
import threading

import numpy as np
import pytest

pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")

from judo.core.errors import MissingExtraError
from judo.core.policies.onnx_policy import OnnxPolicy, write_linear_policy, write_mlp_policy
from judo.core.policy import PolicyError

RNG = np.random.default_rng(0)
W = RNG.normal(size=(3, 5))
B = RNG.normal(size=3)


@pytest.mark.parametrize("fixed_batch", [False, True])
@pytest.mark.parametrize("batch", [1, 300])
def test_a_linear_policy_gives_the_matrix_product(tmp_path, fixed_batch, batch):
    path = write_linear_policy(tmp_path / "linear.onnx", W, B, fixed_batch=fixed_batch)
    policy = OnnxPolicy(path)
    observations = RNG.normal(size=(batch, 5))
    actions = policy.act(observations)
    assert (policy.observation_size, policy.action_size, policy.horizon, policy.kind) == (
        5,
        3,
        1,
        "action",
    )
    assert policy.fixed_batch is fixed_batch
    assert actions.shape == (batch, 1, 3) and actions.dtype == np.float64
    # float32 weights and arithmetic: exact to float32's precision
    expected = observations.astype(np.float32) @ W.astype(np.float32).T + B.astype(np.float32)
    np.testing.assert_allclose(actions[:, 0], expected, rtol=1e-5, atol=1e-5)


def test_a_chunk_policy_gives_batch_by_horizon_by_action(tmp_path):
    weight = RNG.normal(size=(4 * 2, 5))
    policy = OnnxPolicy(write_linear_policy(tmp_path / "chunk.onnx", weight, horizon=4))
    observations = RNG.normal(size=(7, 5))
    actions = policy.act(observations)
    assert (policy.horizon, policy.action_size, policy.kind) == (4, 2, "chunk")
    expected = (observations.astype(np.float32) @ weight.astype(np.float32).T).reshape(7, 4, 2)
    np.testing.assert_allclose(actions, expected, rtol=1e-5, atol=1e-5)


def test_an_mlp_with_normalization_matches_numpy(tmp_path):
    layers = [
        (RNG.normal(size=(8, 5)), RNG.normal(size=8)),
        (RNG.normal(size=(3, 8)), RNG.normal(size=3)),
    ]
    mean, std = RNG.normal(size=5), RNG.uniform(0.5, 2, size=5)
    out_mean, out_std = RNG.normal(size=3), RNG.uniform(0.5, 2, size=3)
    path = write_mlp_policy(
        tmp_path / "mlp.onnx", layers, input_scale=(mean, std), output_scale=(out_mean, out_std)
    )
    observations = RNG.normal(size=(11, 5))
    hidden = np.tanh(((observations - mean) / std) @ layers[0][0].T + layers[0][1])
    expected = (hidden @ layers[1][0].T + layers[1][1]) * out_std + out_mean
    np.testing.assert_allclose(
        OnnxPolicy(path).act(observations)[:, 0], expected, rtol=1e-4, atol=1e-4
    )


def test_metadata_round_trips_and_a_mismatch_is_one_line(tmp_path):
    meta = {"task": "cartpole", "kind": "action", "training_command": "python -m judo distill x.h5"}
    policy = OnnxPolicy(write_linear_policy(tmp_path / "p.onnx", W, B, metadata=meta))
    assert {k: policy.metadata[k] for k in meta} == meta and policy.name == "p"
    policy.check_fits("cartpole", 5, 3)
    with pytest.raises(
        PolicyError, match="^policy 'p' was made for task 'cartpole', not 'pendulum'$"
    ):
        policy.check_fits("pendulum", 5, 3)
    with pytest.raises(
        PolicyError, match="takes observations of size 5, but the task cartpole gives 4$"
    ):
        policy.check_fits("cartpole", 4, 3)
    with pytest.raises(PolicyError, match=r"takes observations of shape \(B, 5\), got \(2, 4\)"):
        policy.act(np.zeros((2, 4)))


def test_bad_files_are_one_line_errors(tmp_path):
    with pytest.raises(PolicyError, match="does not exist"):
        OnnxPolicy(tmp_path / "missing.onnx")
    (tmp_path / "junk.onnx").write_bytes(b"not a protobuf at all")
    with pytest.raises(PolicyError, match="cannot read policy file .* as ONNX"):
        OnnxPolicy(tmp_path / "junk.onnx")


def test_without_the_extra_the_error_names_it(tmp_path, monkeypatch):
    path = write_linear_policy(tmp_path / "p.onnx", W, B)
    # makes `import onnxruntime` raise ImportError
    monkeypatch.setitem(sys.modules, "onnxruntime", None)
    with pytest.raises(MissingExtraError, match=r'pip install -e "\.\[policy\]"'):
        OnnxPolicy(path)


def test_checked_act_refuses_non_finite_actions(tmp_path):
    policy = OnnxPolicy(write_linear_policy(tmp_path / "p.onnx", W, B))
    with pytest.raises(PolicyError, match="non-finite"):
        policy.checked_act(np.full((2, 5), np.inf))


def test_bound_runs_give_the_bits_of_a_plain_run_on_every_thread_and_batch_size(tmp_path):
    """`act` runs on each thread's I/O binding per batch size (preallocated buffers): the actions
    are those of `InferenceSession.run` bit for bit, from several threads at once, and a returned
    array is the caller's (the next call does not overwrite it)."""
    layers = [
        (RNG.normal(size=(16, 5)), RNG.normal(size=16)),
        (RNG.normal(size=(2 * 3, 16)), RNG.normal(size=6)),
    ]
    policy = OnnxPolicy(write_mlp_policy(tmp_path / "mlp.onnx", layers, horizon=2))
    batches = [RNG.normal(size=(batch, 5)) for batch in (1, 4, 4, 33, 1, 7)]
    session = policy._session

    def plain(observations):
        run = session.run(None, {session.get_inputs()[0].name: observations.astype(np.float32)})[0]
        return run.astype(np.float64)

    expected = [plain(observations) for observations in batches]
    first = policy.act(batches[0])
    results: dict[int, list[np.ndarray]] = {}

    def work(thread: int) -> None:
        results[thread] = [policy.act(observations) for _ in range(20) for observations in batches]

    threads = [threading.Thread(target=work, args=(thread,)) for thread in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for thread in range(3):
        assert len(results[thread]) == 20 * len(batches)
        for i, actions in enumerate(results[thread]):
            assert actions.dtype == np.float64 and actions.shape == (len(batches[i % 6]), 2, 3)
            np.testing.assert_array_equal(actions, expected[i % 6])
    np.testing.assert_array_equal(first, expected[0])  # unchanged by the calls since
    assert not np.array_equal(expected[0], expected[4])  # the two batches of one row differ
