"""A periodic gait policy in numpy: a central pattern generator whose joint targets the command
shapes, with feedback; `GaitPolicy` runs one through judo's Policy protocol from a small JSON file.

Each joint's target is the standing pose plus a clock's first two harmonics, each harmonic's size a
linear function of the command, plus a linear feedback on a few proprioceptive values (the trunk's
gyro and its gravity direction, by default):

    target_j = home_j + sum_{b, c} W[j, b, c] * phase_b(leg of j) * command_c + sum_f K[j, f] * feedback_f
    phase = [1, cos p, sin p, cos 2p, sin 2p],  p = 2 pi (gait frequency * t + the leg's offset)
    command = [1, vx, vy, yaw rate]

In a trot the diagonal legs run half a cycle apart: their first harmonic flips sign (`phase_signs`).
The clock arrives as [cos, sin] of the trot's phase in the observation (quadruped's
`locomotion_observation`, go2_walk's `policy_observation`), so the policy keeps no state and runs
wherever the observation is built: every rollout, and the plant.

`gait_actions` runs a batch of policies, one parameter row each (gait-search's candidates,
judo.learning.policy_search); `GaitPolicy` runs one row, read with its layout from the JSON file
`save_gait_policy` writes (no onnxruntime needed). judo.learning.gait_policy writes the same policy
as an ONNX graph.
"""  # noqa: E501

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from judo.core.policy import Policy, PolicyError

HARMONICS = 5
"""Phase features per leg: [1, cos p, sin p, cos 2p, sin 2p]."""
COMMAND_FEATURES = 4
"""Command features: [1, vx, vy, yaw rate]."""
FORMAT = "judo-gait-policy-1"
"""The "format" a gait policy's JSON file carries."""


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

    def to_json(self) -> dict[str, Any]:
        """The layout as JSON-ready lists."""
        names = ("home", "command_columns", "clock_columns", "feedback_columns", "phase_signs")
        return {
            **{name: np.asarray(getattr(self, name)).tolist() for name in names},
            "observation_size": int(self.observation_size),
        }

    @classmethod
    def from_json(cls, values: dict[str, Any]) -> "GaitLayout":
        """The layout `to_json` wrote."""
        columns = {
            name: np.asarray(values[name], dtype=int)
            for name in ("command_columns", "clock_columns", "feedback_columns")
        }
        return cls(
            home=np.asarray(values["home"], dtype=float),
            phase_signs=np.asarray(values["phase_signs"], dtype=float),
            observation_size=int(values["observation_size"]),
            **columns,
        )


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


class GaitPolicy(Policy):
    """One gait policy, (P,) `parameters` on `layout`, as a per-step action policy (horizon 1): (B,
    O) observations -> (B, 1, J) joint targets, in numpy; `gait_actions`' targets, computed as the
    ONNX graph does (the phase signs folded into one (20, J) matrix on the outer product of the
    phase and command features), a few small products a call. Keeps no state between calls."""

    horizon = 1
    deterministic = True

    def __init__(
        self, parameters: np.ndarray, layout: GaitLayout, metadata: dict[str, str] | None = None
    ) -> None:
        self.parameters = np.asarray(parameters, dtype=float).reshape(1, -1)
        if self.parameters.shape[1] != layout.num_parameters:
            raise PolicyError(
                f"a gait policy on this layout takes {layout.num_parameters} parameters, got "
                f"{self.parameters.shape[1]}"
            )
        self.layout = layout
        self.observation_size, self.action_size = layout.observation_size, layout.num_joints
        self.metadata = dict(metadata or {})
        weights, gains = layout.split(self.parameters)
        signed = weights[0] * layout.signed_harmonics()[:, :, None]  # (J, 5, 4)
        self._rhythm = signed.reshape(layout.num_joints, -1).T.copy()  # (20, J): row b * 4 + c
        self._feedback = gains[0].T.copy()  # (F, J)

    def act(self, observations: np.ndarray) -> np.ndarray:
        observations = np.asarray(observations, dtype=float)
        layout, batch = self.layout, len(observations)
        features = np.empty((batch, HARMONICS, COMMAND_FEATURES))
        phase = phase_features(observations[:, layout.clock_columns])  # (B, 5)
        features[:, :, 0] = phase
        features[:, :, 1:] = phase[:, :, None] * observations[:, None, layout.command_columns]
        targets = features.reshape(batch, -1) @ self._rhythm
        targets += observations[:, layout.feedback_columns] @ self._feedback
        targets += layout.home
        return targets[:, None, :]

    @classmethod
    def load(cls, path: str | Path) -> "GaitPolicy":
        """The policy `save_gait_policy` wrote to `path`; PolicyError for a missing or unreadable
        file."""
        path = Path(path)
        try:
            values = json.loads(path.read_text())
            if values.get("format") != FORMAT:
                raise ValueError(f"its format is {values.get('format')!r}, not {FORMAT!r}")
            layout = GaitLayout.from_json(values["layout"])
            metadata = {str(k): str(v) for k, v in values.get("metadata", {}).items()}
            metadata.setdefault("name", path.stem)
            return cls(np.asarray(values["parameters"], dtype=float), layout, metadata)
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise PolicyError(f"cannot read gait policy file {str(path)!r}: {err}") from None


def save_gait_policy(
    path: Path, parameters: np.ndarray, layout: GaitLayout, metadata: dict[str, str]
) -> Path:
    """Write (P,) `parameters` on `layout` with `metadata` as the JSON file `GaitPolicy.load` reads,
    through a temporary file (no half file on failure); returns `path`."""
    values = {
        "format": FORMAT,
        "metadata": metadata,
        "layout": layout.to_json(),
        "parameters": [float(p) for p in np.asarray(parameters, dtype=float)],
    }
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        os.chmod(temporary, 0o644)  # mkstemp's 0o600 would hide a shipped file from other users
        with os.fdopen(handle, "w") as file:
            json.dump(values, file, indent=1)
            file.write("\n")
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return path
