"""A periodic gait policy: a central pattern generator whose joint targets the command shapes, with
feedback.

Each joint's target is the standing pose plus a clock's first two harmonics, each harmonic's size a
linear function of the command, plus a linear feedback on a few proprioceptive values (the trunk's
gyro and its gravity direction, by default):

    target_j = home_j + sum_{b, c} W[j, b, c] * phase_b(leg of j) * command_c + sum_f K[j, f] * feedback_f
    phase = [1, cos p, sin p, cos 2p, sin 2p],  p = 2 pi (gait frequency * t + the leg's offset)
    command = [1, vx, vy, yaw rate]

In a trot the diagonal legs run half a cycle apart: their first harmonic flips sign (`phase_signs`).
The clock arrives as [cos, sin] of the trot's phase in the observation (quadruped's
`locomotion_observation`), so the policy itself keeps no state and runs wherever the observation is
built: every rollout, and the plant.

`gait_actions` runs a batch of policies, one parameter row each (the search's candidates);
`gait_policy_model` writes one as an ONNX graph that gives the same targets (float32), for
`OnnxPolicy`.
"""  # noqa: E501

from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.policies.onnx_policy import _onnx, model_of_graph

HARMONICS = 5
"""Phase features per leg: [1, cos p, sin p, cos 2p, sin 2p]."""
COMMAND_FEATURES = 4
"""Command features: [1, vx, vy, yaw rate]."""


@dataclass(frozen=True)
class GaitLayout:
    """Where a gait policy reads its inputs in an (B, O) observation, and its joints' phasing.

    Attributes:
        home: (J,) the standing pose's joint targets, what all-zero parameters give.
        command_columns: (3,) columns of [vx, vy, yaw rate].
        clock_columns: (2,) columns of [cos, sin] of the gait's phase.
        feedback_columns: (F,) columns fed back linearly.
        phase_signs: (J,) +1, or -1 for a joint on a leg half a cycle behind (its first harmonic
            flips).
        observation_size: O.
    """

    home: np.ndarray
    command_columns: np.ndarray
    clock_columns: np.ndarray
    feedback_columns: np.ndarray
    phase_signs: np.ndarray
    observation_size: int

    @property
    def num_joints(self) -> int:
        return len(self.home)

    @property
    def num_parameters(self) -> int:
        """P: J * 5 * 4 harmonic weights, then J * F feedback gains."""
        return self.num_joints * (HARMONICS * COMMAND_FEATURES + len(self.feedback_columns))

    def split(self, parameters: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, P) parameters -> (B, J, 5, 4) harmonic weights and (B, J, F) feedback gains."""
        batch, joints = len(parameters), self.num_joints
        cut = joints * HARMONICS * COMMAND_FEATURES
        weights = parameters[:, :cut].reshape(batch, joints, HARMONICS, COMMAND_FEATURES)
        return weights, parameters[:, cut:].reshape(batch, joints, len(self.feedback_columns))

    def signed_harmonics(self) -> np.ndarray:
        """(J, 5) each joint's sign on [1, cos p, sin p, cos 2p, sin 2p]."""
        signs = np.ones((self.num_joints, HARMONICS))
        signs[:, 1:3] = self.phase_signs[:, None]
        return signs


def phase_features(clock: np.ndarray) -> np.ndarray:
    """(B, 5) [1, cos p, sin p, cos 2p, sin 2p] from (B, 2) [cos p, sin p]."""
    cos, sin = clock[:, 0], clock[:, 1]
    return np.stack([np.ones_like(cos), cos, sin, cos * cos - sin * sin, 2.0 * sin * cos], axis=1)


def gait_actions(
    parameters: np.ndarray, observations: np.ndarray, layout: GaitLayout
) -> np.ndarray:
    """(B, J) joint targets of (B, P) parameter rows (one policy per row) on (B, O) observations."""
    weights, gains = layout.split(np.asarray(parameters, dtype=float))
    # (B, J, 5)
    phase = (
        phase_features(observations[:, layout.clock_columns])[:, None, :]
        * layout.signed_harmonics()
    )
    command = np.concatenate(
        [np.ones((len(observations), 1)), observations[:, layout.command_columns]], axis=1
    )
    rhythm = np.einsum("bjkc,bjk,bc->bj", weights, phase, command)
    feedback = np.einsum("bjf,bf->bj", gains, observations[:, layout.feedback_columns])
    return layout.home + rhythm + feedback


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
