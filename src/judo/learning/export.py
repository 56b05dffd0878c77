"""A TrainedPolicy as an ONNX file that needs nothing else to run, and its loss curves as a PNG.

A small MLP is simpler to write straight to an ONNX graph with the onnx helper API than to trace
through an exporter, so distill does that (no exporter dependency; onnx is a core dependency):
  - regression: `judo.core.policies.onnx_policy.mlp_policy_model` with the normalization inside the
    graph;
  - flow: the same layers as a velocity field, unrolled `flow_steps` Euler steps from
    RandomNormalLike noise (times `noise_scale`; 0 gives the deterministic sample, the flow's mean
    path) in the graph.
Both take (B, O) observations and give (B, A) actions or (B, H, A) chunks, float32.

The metadata (`metadata_props`, read by `OnnxPolicy.metadata`) carries the task, kind, head,
observation layout, normalization, the controller fields to serve it with (control_freq; horizon and
spline_order for a chunk) and the training command.
"""

import json
from pathlib import Path
from typing import Any

import numpy as np

from judo.cli_shared import optional_pyplot
from judo.core.policies.onnx_policy import _onnx, mlp_policy_model, model_of_graph, save_model
from judo.learning.networks import ACTIVATION
from judo.learning.pairs import DistillError, TrainingPairs
from judo.learning.training import TrainedPolicy


def policy_metadata(
    trained: TrainedPolicy, pairs: TrainingPairs, command: str, name: str
) -> dict[str, str]:
    """The ONNX file's metadata_props: what the policy is for and how it was made, all strings."""
    return {
        "name": name,
        "task": pairs.task,
        "kind": pairs.kind,
        "head": trained.head,
        "observation": pairs.observation_layout,
        "observation_size": str(len(trained.input_scale[0])),
        "normalization": json.dumps(
            {
                "observation_mean": trained.input_scale[0].tolist(),
                "observation_std": trained.input_scale[1].tolist(),
                "target_mean": trained.output_scale[0].tolist(),
                "target_std": trained.output_scale[1].tolist(),
                "in_graph": True,
            }
        ),
        "training_command": command,
        "training_episodes": str(len(trained.train_episodes)),
        "validation_episodes": str(len(trained.validation_episodes)),
        "training_seconds": f"{trained.seconds:.1f}",
        "best_validation_loss": f"{min(trained.history['validation'], default=float('nan')):.6g}",
        **pairs.controller,
    }


def policy_model(trained: TrainedPolicy, metadata: dict[str, str], noise_scale: float = 1.0) -> Any:
    """The ONNX ModelProto of `trained` with `metadata`."""
    if trained.head == "regression":
        return mlp_policy_model(
            trained.layers,
            activation=ACTIVATION,
            horizon=trained.horizon,
            metadata=metadata,
            input_scale=trained.input_scale,
            output_scale=trained.output_scale,
        )
    return flow_policy_model(trained, {**metadata, "noise_scale": repr(noise_scale)}, noise_scale)


def flow_policy_model(trained: TrainedPolicy, metadata: dict[str, str], noise_scale: float) -> Any:
    """The flow head's sampler as an ONNX graph: x_0 = noise_scale * N(0, I), then x += v([o, x, k /
    K]) / K for k < K, then x * std + mean (reshaped to (B, H, A) for a chunk)."""
    onnx = _onnx()
    helper, numpy_helper = onnx.helper, onnx.numpy_helper
    initializers, nodes = [], []

    def constant(label: str, array: Any, dtype: Any = np.float32) -> str:
        initializers.append(numpy_helper.from_array(np.asarray(array, dtype=dtype), label))
        return label

    (in_mean, in_std), (out_mean, out_std) = trained.input_scale, trained.output_scale
    obs_size, target_size, steps = len(in_mean), len(out_mean), trained.flow_steps
    nodes.append(
        helper.make_node("Sub", ["observations", constant("in_mean", in_mean)], ["centred"])
    )
    nodes.append(helper.make_node("Div", ["centred", constant("in_std", in_std)], ["o"]))
    nodes.append(
        helper.make_node(
            "MatMul", ["o", constant("zero_d", np.zeros((obs_size, target_size)))], ["zeros"]
        )
    )
    nodes.append(
        helper.make_node(
            "MatMul", ["o", constant("zero_1", np.zeros((obs_size, 1)))], ["zero_column"]
        )
    )
    nodes.append(
        helper.make_node(
            "RandomNormalLike", ["zeros"], ["unit_noise"], dtype=onnx.TensorProto.FLOAT
        )
    )
    nodes.append(
        helper.make_node("Mul", ["unit_noise", constant("noise_scale", noise_scale)], ["x0"])
    )
    for i, (weight, bias) in enumerate(trained.layers):
        constant(f"W{i}", weight)
        constant(f"b{i}", bias)
    x = "x0"
    for k in range(steps):
        nodes.append(
            helper.make_node("Add", ["zero_column", constant(f"t{k}", k / steps)], [f"t{k}_column"])
        )
        nodes.append(helper.make_node("Concat", ["o", x, f"t{k}_column"], [f"in{k}"], axis=1))
        h = f"in{k}"
        for i in range(len(trained.layers)):
            nodes.append(helper.make_node("Gemm", [h, f"W{i}", f"b{i}"], [f"s{k}_l{i}"], transB=1))
            h = f"s{k}_l{i}"
            if i < len(trained.layers) - 1:
                nodes.append(helper.make_node(ACTIVATION, [h], [f"{h}_act"]))
                h = f"{h}_act"
        nodes.append(helper.make_node("Mul", [h, constant(f"dt{k}", 1.0 / steps)], [f"dx{k}"]))
        nodes.append(helper.make_node("Add", [x, f"dx{k}"], [f"x{k + 1}"]))
        x = f"x{k + 1}"
    nodes.append(helper.make_node("Mul", [x, constant("out_std", out_std)], ["scaled"]))
    nodes.append(helper.make_node("Add", ["scaled", constant("out_mean", out_mean)], ["unscaled"]))
    out_shape: list[Any] = ["batch", target_size]
    name = "unscaled"
    if trained.horizon > 1:
        out_shape = ["batch", trained.horizon, trained.action_size]
        shape = constant("chunk_shape", [-1, trained.horizon, trained.action_size], np.int64)
        nodes.append(helper.make_node("Reshape", [name, shape], ["chunk"]))
        name = "chunk"
    nodes.append(helper.make_node("Identity", [name], ["actions"]))
    graph = helper.make_graph(
        nodes,
        "judo_flow_policy",
        [
            helper.make_tensor_value_info(
                "observations", onnx.TensorProto.FLOAT, ["batch", obs_size]
            )
        ],
        [helper.make_tensor_value_info("actions", onnx.TensorProto.FLOAT, out_shape)],
        initializers,
    )
    return model_of_graph(graph, metadata)


def write_policy(
    path: Path, trained: TrainedPolicy, metadata: dict[str, str], noise_scale: float = 1.0
) -> Path:
    """Write the ONNX file (through a temporary file, so a failed write leaves no half file);
    DistillError naming the path where it cannot be written."""
    return save_model(path, policy_model(trained, metadata, noise_scale), DistillError)


def losses_path(out: Path) -> Path:
    """Where the loss curves of the policy at `out` go: POLICY.losses.png beside it."""
    return out.with_name(out.stem + ".losses.png")


def plot_losses(path: Path, trained: TrainedPolicy, title: str) -> Path | None:
    """The training and validation loss per epoch as a PNG at `path` (log scale, the kept epoch
    marked); None without matplotlib."""
    plt = optional_pyplot()
    if plt is None:
        return None
    figure, axes = plt.subplots(figsize=(6, 3.5), dpi=110)
    epochs = np.arange(1, len(trained.history["train"]) + 1)
    axes.plot(epochs, trained.history["train"], label="training")
    axes.plot(epochs, trained.history["validation"], label="validation (held-out episodes)")
    axes.axvline(
        trained.best_epoch + 1,
        color="grey",
        linestyle=":",
        label=f"kept: epoch {trained.best_epoch + 1}",
    )
    axes.set_yscale("log")
    axes.set_xlabel("epoch")
    axes.set_ylabel(f"{trained.head} loss (normalized)")
    axes.set_title(title, fontsize=9)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)
    return path


def copy_policy(source: Path, target: Path) -> Path:
    """Copy the policy file `source` to `target`, its metadata "name" set to `target`'s stem (a
    round's policy shipped as the command's --out is named after the file it is in, not after its
    round)."""
    onnx = _onnx()
    model = onnx.load(str(source))
    for prop in model.metadata_props:
        if prop.key == "name":
            prop.value = target.stem
    onnx.save(model, str(target))
    return target
