"""The gait policy as an ONNX graph: `gait_policy_model` writes one (P,) parameter row of
judo.tasks.gait_policy's central pattern generator as a graph that gives `gait_actions`' targets
(float32), for `OnnxPolicy`. The generator itself (its formula, `GaitLayout`, `gait_actions`, and
`GaitPolicy`, which runs one in numpy from a JSON file) lives there, where a task can load its
shipped policy without onnxruntime.
"""

from typing import Any

import numpy as np

from judo.core.policies.onnx_policy import _onnx, model_of_graph
from judo.tasks.gait_policy import COMMAND_FEATURES, HARMONICS, GaitLayout


def gait_policy_model(parameters: np.ndarray, layout: GaitLayout, metadata: dict[str, str]) -> Any:
    """An ONNX ModelProto (float32, (B, O) -> (B, J)) that computes `gait_actions` of one (P,)
    parameter row.

    The harmonic weights, each joint's phase signs folded in, make one (20, J) matrix, so the graph
    is: the (B, 5) phase features times the (B, 4) command features (an outer product, (B, 20)), a
    MatMul, the feedback's MatMul on the whole observation (zero rows outside `feedback_columns`)
    and the standing pose added.
    """
    onnx = _onnx()
    helper, numpy_helper = onnx.helper, onnx.numpy_helper
    weights, gains = layout.split(np.asarray(parameters, dtype=float)[None])
    signed = weights[0] * layout.signed_harmonics()[:, :, None]  # (J, 5, 4)
    # (20, J): feature (b, c) -> row b * 4 + c
    rhythm_matrix = signed.reshape(layout.num_joints, -1).T
    feedback_matrix = np.zeros((layout.observation_size, layout.num_joints))
    feedback_matrix[layout.feedback_columns] = gains[0].T
    initializers, nodes = [], []

    def constant(label: str, array: Any, dtype: Any = np.float32) -> str:
        initializers.append(numpy_helper.from_array(np.asarray(array, dtype=dtype), label))
        return label

    def node(op: str, inputs: list[str], output: str, **attributes: Any) -> str:
        nodes.append(helper.make_node(op, inputs, [output], **attributes))
        return output

    def columns(label: str, index: np.ndarray) -> str:
        return node(
            "Gather", ["observations", constant(f"{label}_index", index, np.int64)], label, axis=1
        )

    clock, command = (
        columns("clock", layout.clock_columns),
        columns("command", layout.command_columns),
    )
    cos = node("Gather", [clock, constant("zero", 0, np.int64)], "cos", axis=1)  # (B,)
    sin = node("Gather", [clock, constant("one", 1, np.int64)], "sin", axis=1)
    one = node(
        "Add",
        [node("Mul", [cos, constant("nought", 0.0)], "zero_b"), constant("unit", 1.0)],
        "one_b",
    )
    cos2 = node("Sub", [node("Mul", [cos, cos], "cc"), node("Mul", [sin, sin], "ss")], "cos2")
    sin2 = node("Mul", [node("Mul", [sin, cos], "sc"), constant("two", 2.0)], "sin2")
    axis1 = constant("axis1", [1], np.int64)
    stacked = [
        node("Unsqueeze", [name, axis1], f"{name}_col") for name in (one, cos, sin, cos2, sin2)
    ]
    phase = node("Concat", stacked, "phase", axis=1)  # (B, 5)
    command_features = node("Concat", [stacked[0], command], "command_features", axis=1)  # (B, 4)
    outer = node(
        "Mul",
        [
            node("Unsqueeze", [phase, constant("axis2", [2], np.int64)], "phase_3d"),
            node("Unsqueeze", [command_features, axis1], "command_3d"),
        ],
        "outer",
    )  # (B, 5, 4)
    flat = node(
        "Reshape",
        [outer, constant("flat_shape", [-1, HARMONICS * COMMAND_FEATURES], np.int64)],
        "flat",
    )
    rhythm = node("MatMul", [flat, constant("rhythm_matrix", rhythm_matrix)], "rhythm")
    feedback = node(
        "MatMul", ["observations", constant("feedback_matrix", feedback_matrix)], "feedback"
    )
    summed = node("Add", [rhythm, feedback], "summed")
    node("Add", [summed, constant("home", layout.home)], "actions")
    graph = helper.make_graph(
        nodes,
        "judo_gait_policy",
        [
            helper.make_tensor_value_info(
                "observations", onnx.TensorProto.FLOAT, ["batch", layout.observation_size]
            )
        ],
        [
            helper.make_tensor_value_info(
                "actions", onnx.TensorProto.FLOAT, ["batch", layout.num_joints]
            )
        ],
        initializers,
    )
    return model_of_graph(graph, metadata)
