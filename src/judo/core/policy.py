"""The Policy contract: batched observations in, actions or action chunks out.

A policy plugs into judo's one closed loop at three places (docs/policies.md):
  - as the controller: its action (or chunk) is the plan, served and watched like an optimizer's;
  - as proposals: some of an optimizer's candidate knot sequences come from it each update;
  - inside every rollout as a low-level controller: the optimizer plans commands, and every k
    physics steps one batched `act` for each worker's block of rollouts turns commands and state
    into `ctrl` (several threads call `act` at once: a policy must not keep shared mutable state
    between calls).

Write one by hand as a subclass (numpy, any library), or load an exported network with `OnnxPolicy`
(core/policies/onnx_policy.py, on onnxruntime). What a policy sees is the task's to say:
`Task.policy_observation` builds the (B, observation_size) batch.
"""

import abc
from typing import Any

import numpy as np

from judo.core.errors import JudoError

POLICY_KINDS = ("action", "chunk")
"""What a policy's output is: "action" (H = 1, the next control) or "chunk" (H > 1, e.g. a plan's
knots)."""


class PolicyError(JudoError):
    """A policy that does not fit where it is used (another task, another observation or action
    size), or a policy file that cannot be read."""


class NonFiniteActionsError(PolicyError):
    """A policy returned NaN or infinite actions (`Policy.checked_act`); served as a controller, the
    update fails and the plan before it stays in force, so the watchdog sees the plan age."""


class Policy(abc.ABC):
    """Maps a batch of observations to a batch of action chunks.

    Attributes:
        observation_size: the length of one observation, O.
        action_size: the length of one action, A.
        horizon: actions per chunk, H: 1 for a per-step action policy, > 1 for an action chunk.
        metadata: free-form facts about the policy (strings): its "task", "kind", "observation"
            layout,
            "training_command", ...; `check_fits` reads "task" when it is there.
        deterministic: True when equal observations always give equal actions (no sampling inside):
            the controller's proposals then roll out one candidate and repeat it. False by default.
    """

    observation_size: int
    action_size: int
    horizon: int = 1
    metadata: dict[str, str]
    deterministic: bool = False

    @abc.abstractmethod
    def act(self, observations: np.ndarray) -> np.ndarray:
        """(B, observation_size) float observations -> (B, horizon, action_size) float64 actions."""

    @property
    def kind(self) -> str:
        """ "action" (horizon 1) or "chunk" (horizon > 1)."""
        return "action" if self.horizon == 1 else "chunk"

    @property
    def name(self) -> str:
        """What the GUI and evaluate call the policy: metadata's "name", else the class name."""
        return getattr(self, "metadata", {}).get("name") or type(self).__name__

    def check_fits(self, task_name: str | None, observation_size: int, action_size: int) -> None:
        """Raise PolicyError (one line, naming both sides) unless the policy was made for
        `task_name` (when its metadata names a task) and takes `observation_size` observations to
        `action_size` actions."""
        made_for = getattr(self, "metadata", {}).get("task")
        if task_name is not None and made_for and made_for != task_name:
            raise PolicyError(
                f"policy {self.name!r} was made for task {made_for!r}, not {task_name!r}"
            )
        if self.observation_size != observation_size:
            raise PolicyError(
                f"policy {self.name!r} takes observations of size {self.observation_size}, "
                "but the task "
                f"{task_name or '?'!s} gives {observation_size}"
            )
        if self.action_size != action_size:
            raise PolicyError(
                f"policy {self.name!r} gives actions of size {self.action_size}, but the task "
                f"{task_name or '?'!s} needs {action_size}"
            )

    def checked_act(self, observations: np.ndarray, require_finite: bool = True) -> np.ndarray:
        """`act`, with its output checked: (B, horizon, action_size) and (unless `require_finite` is
        False) finite, else PolicyError. A per-step policy's (B, action_size) output is read as (B,
        1, action_size)."""
        actions = np.asarray(self.act(observations), dtype=float)
        batch = observations.shape[0]
        if actions.shape == (batch, self.action_size) and self.horizon == 1:
            actions = actions[:, None, :]
        if actions.shape != (batch, self.horizon, self.action_size):
            raise PolicyError(
                f"policy {self.name!r} returned shape {actions.shape}, expected "
                f"({batch}, {self.horizon}, {self.action_size})"
            )
        if require_finite and not np.isfinite(actions).all():
            raise NonFiniteActionsError(f"policy {self.name!r} returned non-finite actions")
        return actions

    def describe(self) -> dict[str, Any]:
        """A JSON-ready summary: name, kind, sizes and metadata."""
        return {
            "name": self.name,
            "kind": self.kind,
            "observation_size": self.observation_size,
            "action_size": self.action_size,
            "horizon": self.horizon,
            "metadata": dict(getattr(self, "metadata", {})),
        }
