"""`OnnxPolicy`: a Policy read from an ONNX file and run on onnxruntime's CPU provider; and writers
for small policies (linear laws and MLPs) built with the onnx helper API, so tests, examples and
`distill` need no exporter and nothing downloaded.

The file's graph takes one input of shape (B, O) and gives (B, A) (a per-step action policy, as
Isaac Lab and mjlab export) or (B, H, A) (an action chunk). Its `metadata_props` may say what it is
for ("task", "kind", "observation", "normalization", "training_command", "name");
`Policy.check_fits` reads "task".

A file exported with a fixed batch of 1 (as most exporters write) is rewritten at load: the first
dimension of its input and outputs becomes a symbolic "batch", the stored intermediate shapes are
dropped, and a batch of 2 is run to check the graph still works. A graph that hard-codes the batch
inside (a Reshape to [1, ...]) fails that check and is then run one row at a time, with a warning
saying so.

Importing this module imports neither onnx nor onnxruntime; loading or writing a policy does, and
without the `policy` extra (onnxruntime and onnx, also core dependencies) the error names it.
"""

import functools
import threading
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.errors import import_extra
from judo.core.policy import Policy, PolicyError

FEATURE = "ONNX policies (OnnxPolicy, --policy FILE.onnx)"
EXTRA = "policy"
OPSET = 17
"""The ONNX opset the writers target (onnxruntime 1.17 and later run it)."""


def _onnx(feature: str = FEATURE) -> Any:
    return import_extra("onnx", feature, EXTRA)


def _onnxruntime(feature: str = FEATURE) -> Any:
    return import_extra("onnxruntime", feature, EXTRA)


def _dims(value_info: Any) -> list[Any]:
    """Each dimension of a graph input or output: an int, a symbolic name, or None when unknown."""
    dims = []
    for dim in value_info.type.tensor_type.shape.dim:
        dims.append(dim.dim_value if dim.HasField("dim_value") else (dim.dim_param or None))
    return dims


class OnnxPolicy(Policy):
    """A policy read from an ONNX file, run on onnxruntime's CPU provider.

    Args:
        path: the .onnx file: one input (B, O), first output (B, A) or (B, H, A).
        threads: onnxruntime's intra-op threads. 1 by default: a small network on a batch of a few
            thousand rows is fastest on one thread, and the caller's own threads do the rest.
        feature: what needs the policy, as a missing onnxruntime's error names it (a task that ships
            one names itself).
    Raises PolicyError for a missing or unreadable file or a graph of another shape, and
    MissingExtraError (naming the `policy` extra) without onnxruntime.
    """

    def __init__(self, path: str | Path, threads: int = 1, feature: str = FEATURE) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise PolicyError(
                f"policy file {str(self.path)!r} does not exist; expected an .onnx file"
            )
        onnx, ort = _onnx(feature), _onnxruntime(feature)
        try:
            model = onnx.load(str(self.path))
            onnx.checker.check_model(model)
        except Exception as err:  # onnx raises several unrelated types for a bad file
            raise PolicyError(
                f"cannot read policy file {str(self.path)!r} as ONNX: {str(err).splitlines()[0]}"
            ) from None
        initializers = {init.name for init in model.graph.initializer}
        inputs = [value for value in model.graph.input if value.name not in initializers]
        if len(inputs) != 1 or not model.graph.output:
            raise PolicyError(
                f"policy file {str(self.path)!r} has {len(inputs)} inputs and "
                f"{len(model.graph.output)} outputs; "
                "expected one input (batch, observation_size) and an output (batch, "
                "[horizon,] action_size)"
            )
        in_dims, out_dims = _dims(inputs[0]), _dims(model.graph.output[0])
        if len(in_dims) != 2 or not isinstance(in_dims[1], int) or len(out_dims) not in (2, 3):
            raise PolicyError(
                f"policy file {str(self.path)!r} maps shape {in_dims} to {out_dims}; "
                "expected (batch, O) to "
                "(batch, A) or (batch, H, A) with O, H and A fixed"
            )
        if not all(isinstance(d, int) and d > 0 for d in out_dims[1:]):
            raise PolicyError(
                f"policy file {str(self.path)!r} gives output shape {out_dims}; expected fixed H "
                "and A"
            )
        self.observation_size = int(in_dims[1])
        self.horizon = 1 if len(out_dims) == 2 else int(out_dims[1])
        self.action_size = int(out_dims[-1])
        # (A,) or (H, A), as the graph writes it
        self._out_tail = tuple(int(d) for d in out_dims[1:])
        self.metadata = {prop.key: prop.value for prop in model.metadata_props}
        self.metadata.setdefault("name", self.path.stem)
        self.fixed_batch = in_dims[0] == 1
        if self.fixed_batch:
            _make_batch_symbolic(model)
        options = ort.SessionOptions()
        options.intra_op_num_threads = max(1, threads)
        options.inter_op_num_threads = 1
        self._session = ort.InferenceSession(
            model.SerializeToString(), options, providers=["CPUExecutionProvider"]
        )
        self._input = self._session.get_inputs()[0].name
        self._output = self._session.get_outputs()[0].name
        self._dtype = np.float64 if "double" in self._session.get_inputs()[0].type else np.float32
        self._out_dtype = _FLOAT_TYPES.get(self._session.get_outputs()[0].type)
        self._ort, self._run_options = ort, ort.RunOptions()
        self._bindings = threading.local()  # each calling thread's {batch: Binding}
        self._row_by_row = False
        if self.fixed_batch:
            try:
                self._run(np.zeros((2, self.observation_size), dtype=self._dtype))
            except Exception:  # onnxruntime's errors for a hard-coded batch vary
                self._row_by_row = True
                warnings.warn(
                    f"policy {str(self.path)!r} hard-codes a batch of 1 inside its graph; it "
                    "runs one row at a time",
                    stacklevel=2,
                )

    def _run(self, observations: np.ndarray) -> np.ndarray:
        return self._session.run([self._output], {self._input: observations})[0]

    def _binding(self, batch: int) -> "_Binding":
        """The calling thread's I/O binding for a batch of `batch` rows, made on its first use."""
        bindings = getattr(self._bindings, "by_batch", None)
        if bindings is None:
            bindings = self._bindings.by_batch = {}
        binding = bindings.get(batch)
        if binding is None:
            if len(bindings) >= MAX_BINDINGS:  # a caller of ever new batch sizes: start afresh
                bindings.clear()
            binding = bindings[batch] = _Binding(
                self._session,
                self._ort,
                self._run_options,
                (self._input, self._output),
                ((batch, self.observation_size), self._dtype),
                ((batch, *self._out_tail), self._out_dtype),
            )
        return binding

    def act(self, observations: np.ndarray) -> np.ndarray:
        """(B, observation_size) -> (B, horizon, action_size) float64; PolicyError for another
        width.

        The graph runs on the calling thread's I/O binding for its batch size: the observations are
        converted into a preallocated input buffer and the graph writes into a preallocated output
        buffer, so a call allocates only the float64 actions it returns, and onnxruntime holds no
        GIL for the run itself."""
        observations = np.asarray(observations)
        if observations.ndim != 2 or observations.shape[1] != self.observation_size:
            raise PolicyError(
                f"policy {self.name!r} takes observations of shape (B, {self.observation_size}), "
                f"got {observations.shape}"
            )
        batch = observations.shape[0]
        if not self._row_by_row and self._out_dtype is not None and batch > 0:
            binding = self._binding(batch)
            np.copyto(binding.inputs, observations, casting="unsafe")  # float32 as astype rounds it
            binding.run()
            return binding.outputs.astype(np.float64).reshape(batch, self.horizon, self.action_size)
        observations = np.ascontiguousarray(observations, dtype=self._dtype)
        if self._row_by_row:
            rows = [self._run(observations[i : i + 1]) for i in range(observations.shape[0])]
            actions = (
                np.concatenate(rows) if rows else np.zeros((0, self.horizon, self.action_size))
            )
        else:
            actions = self._run(observations)
        return np.asarray(actions, dtype=np.float64).reshape(
            observations.shape[0], self.horizon, self.action_size
        )


MAX_BINDINGS = 16
"""Most batch sizes a thread keeps an I/O binding for at once (the plant's 1, each worker's block,
proposals)."""
_FLOAT_TYPES = {"tensor(float)": np.float32, "tensor(double)": np.float64}
"""The output types `act` binds into a preallocated buffer; any other runs through
`InferenceSession.run`."""


class _Binding:
    """One thread's onnxruntime I/O binding for one batch size: the (B, O) input and (B, [H,] A)
    output buffers the graph reads and writes in place, and `run`, which runs the graph on them (the
    GIL released meanwhile)."""

    def __init__(
        self,
        session: Any,
        ort: Any,
        run_options: Any,
        names: tuple[str, str],
        inputs: tuple[tuple[int, ...], Any],
        outputs: tuple[tuple[int, ...], Any],
    ) -> None:
        self.inputs, self.outputs = np.zeros(inputs[0], inputs[1]), np.zeros(outputs[0], outputs[1])
        binding = session.io_binding()
        binding.bind_ortvalue_input(names[0], ort.OrtValue.ortvalue_from_numpy(self.inputs))
        binding.bind_ortvalue_output(names[1], ort.OrtValue.ortvalue_from_numpy(self.outputs))
        self._binding = binding  # holds the OrtValues, which hold the buffers
        # The C session and binding where this onnxruntime has them: its Python wrapper's
        # checks (for WebGPU graph capture) cost about a microsecond per run; else the public call.
        c_session, c_binding = getattr(session, "_sess", None), getattr(binding, "_iobinding", None)
        if (
            c_session is not None
            and c_binding is not None
            and hasattr(c_session, "run_with_iobinding")
        ):
            self.run = functools.partial(c_session.run_with_iobinding, c_binding, run_options)
        else:
            self.run = functools.partial(session.run_with_iobinding, binding, run_options)


def _make_batch_symbolic(model: Any) -> None:
    """Make the first dimension of `model`'s input and outputs a symbolic "batch"; drop stored inner
    shapes."""
    for value in [*model.graph.input, *model.graph.output]:
        dims = value.type.tensor_type.shape.dim
        if dims:
            dims[0].ClearField("dim_value")
            dims[0].dim_param = "batch"
    del model.graph.value_info[:]


# ---- writers -------------------------------------------------------------------------------------
def mlp_policy_model(
    layers: Sequence[tuple[np.ndarray, np.ndarray]],
    activation: str = "Tanh",
    horizon: int = 1,
    metadata: Mapping[str, str] | None = None,
    fixed_batch: bool = False,
    input_scale: tuple[np.ndarray, np.ndarray] | None = None,
    output_scale: tuple[np.ndarray, np.ndarray] | None = None,
) -> Any:
    """An ONNX ModelProto (float32) for an MLP: y = L_n(act(... act(L_1(x)))), L_i(x) = x W_i^T +
    b_i.

    Args:
        layers: [(W_i (out_i, in_i), b_i (out_i,))]; one layer is a linear law. The last out size is
            H * A.
        activation: the ONNX op between layers ("Tanh", "Relu", "Elu", ...).
        horizon: H; above 1 the output (B, H * A) is reshaped to (B, H, A).
        metadata: stored as the file's metadata_props (string keys and values).
        fixed_batch: write the batch dimension as a fixed 1 (as many exporters do) instead of
            symbolic.
        input_scale: (mean (O,), std (O,)): the graph normalizes x to (x - mean) / std first.
        output_scale: (mean (H * A,), std (H * A,)): the graph maps its output y to y * std + mean
            last.
    """
    onnx = _onnx()
    helper, numpy_helper = onnx.helper, onnx.numpy_helper
    if not layers:
        raise PolicyError("an MLP policy needs at least one layer")
    sizes = [np.asarray(layers[0][0]).shape[1]] + [np.asarray(w).shape[0] for w, _ in layers]
    out_size = sizes[-1]
    if horizon < 1 or out_size % horizon:
        raise PolicyError(
            f"the last layer gives {out_size} values, which horizon {horizon} does not divide"
        )
    initializers, nodes, name = [], [], "observations"

    def constant(label: str, array: np.ndarray) -> str:
        initializers.append(numpy_helper.from_array(np.asarray(array, dtype=np.float32), label))
        return label

    if input_scale is not None:
        mean, std = input_scale
        nodes.append(helper.make_node("Sub", [name, constant("in_mean", mean)], ["centred"]))
        nodes.append(helper.make_node("Div", ["centred", constant("in_std", std)], ["normalized"]))
        name = "normalized"
    for i, (weight, bias) in enumerate(layers):
        weight, bias = np.asarray(weight), np.asarray(bias)
        if weight.shape != (sizes[i + 1], sizes[i]) or bias.shape != (sizes[i + 1],):
            raise PolicyError(
                f"layer {i} has W {weight.shape} and b {bias.shape}; expected "
                f"{(sizes[i + 1], sizes[i])}"
            )
        gemm = f"layer{i}"
        nodes.append(
            helper.make_node(
                "Gemm", [name, constant(f"W{i}", weight), constant(f"b{i}", bias)], [gemm], transB=1
            )
        )
        name = gemm
        if i < len(layers) - 1:
            nodes.append(helper.make_node(activation, [gemm], [f"{gemm}_act"]))
            name = f"{gemm}_act"
    if output_scale is not None:
        mean, std = output_scale
        nodes.append(helper.make_node("Mul", [name, constant("out_std", std)], ["scaled"]))
        nodes.append(helper.make_node("Add", ["scaled", constant("out_mean", mean)], ["unscaled"]))
        name = "unscaled"
    batch: int | str = 1 if fixed_batch else "batch"
    out_shape: list[int | str] = [batch, out_size]
    if horizon > 1:
        out_shape = [batch, horizon, out_size // horizon]
        initializers.append(
            numpy_helper.from_array(
                np.array([-1, horizon, out_size // horizon], np.int64), "chunk_shape"
            )
        )
        nodes.append(helper.make_node("Reshape", [name, "chunk_shape"], ["chunk"]))
        name = "chunk"
    nodes.append(helper.make_node("Identity", [name], ["actions"]))
    graph = helper.make_graph(
        nodes,
        "judo_policy",
        [helper.make_tensor_value_info("observations", onnx.TensorProto.FLOAT, [batch, sizes[0]])],
        [helper.make_tensor_value_info("actions", onnx.TensorProto.FLOAT, out_shape)],
        initializers,
    )
    return model_of_graph(graph, metadata)


def model_of_graph(graph: Any, metadata: Mapping[str, str] | None) -> Any:
    """The checked ONNX ModelProto of `graph` (opset OPSET, IR 8) with `metadata` as its
    metadata_props."""
    onnx = _onnx()
    helper = onnx.helper
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="judo"
    )
    model.ir_version = 8  # what onnxruntime 1.17 and later read
    helper.set_model_props(model, {str(k): str(v) for k, v in (metadata or {}).items()})
    onnx.checker.check_model(model)
    return model


def save_model(path: Path, model: Any, error: type[Exception] = PolicyError) -> Path:
    """Write `model` to `path` through a temporary file, so a failed write leaves no half file;
    `error` (one line, naming the path) where it cannot be written."""
    partial = path.with_name(path.name + ".partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial.write_bytes(model.SerializeToString())
        partial.replace(path)
    except OSError as err:
        raise error(f"cannot write the policy to {str(path)!r}: {err.strerror or err}") from None
    return path


def write_mlp_policy(
    path: str | Path, layers: Sequence[tuple[np.ndarray, np.ndarray]], **kwargs: Any
) -> Path:
    """Write `mlp_policy_model(layers, **kwargs)` to `path` and return it."""
    path = Path(path)
    path.write_bytes(mlp_policy_model(layers, **kwargs).SerializeToString())
    return path


def write_linear_policy(
    path: str | Path,
    weight: np.ndarray,
    bias: np.ndarray | None = None,
    metadata: Mapping[str, str] | None = None,
    fixed_batch: bool = False,
    horizon: int = 1,
) -> Path:
    """Write the linear policy a = W o + b (W (H * A, O), b (H * A,), zeros by default) to
    `path`."""
    weight = np.atleast_2d(np.asarray(weight, dtype=float))
    bias = np.zeros(weight.shape[0]) if bias is None else np.asarray(bias, dtype=float)
    return write_mlp_policy(
        path, [(weight, bias)], horizon=horizon, metadata=metadata, fixed_batch=fixed_batch
    )
