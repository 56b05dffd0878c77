"""The rollout backend interface and the backends' names; core/rollouts/factory.py builds a backend
from its name.

A rollout backend is the one call the Controller makes: from one initial state and per-step controls
to per-step states and sensor values. `RolloutPool` (core/rollouts/rollout.py, CPU threads) and
`WarpRollout` (core/rollouts/warp_rollout.py, MuJoCo Warp on a GPU) implement `RolloutBackend`, so
the Controller's loop stays written once.

The dependencies point one way: each backend module imports this one, and this module imports
neither. The factory (core/rollouts/factory.py), above them, names each backend class by its dotted
path and imports that module only when the backend is asked for, so `import judo` never imports
warp.
"""

import abc
from collections.abc import Sequence
from typing import Any, Literal, Protocol, TypeVar, get_args

import mujoco
import numpy as np

from judo.core.errors import JudoError
from judo.core.planner import CancelFlag

BackendT = TypeVar("BackendT", bound="RolloutBackend")


class RolloutBackend(abc.ABC):
    """Rolls out a batch of control sequences from one initial state.

    A backend is a context manager: `with RolloutPool(model) as pool:` closes it (its threads or
    device memory) on the way out.

    Attributes:
        model: the planning model every rollout runs on.
        num_workers: host threads the backend rolls out on (1 for a GPU backend).
        reward_threads: host threads for the rewards of a large batch (see below).
    """

    model: mujoco.MjModel
    num_workers: int
    name: str = ""
    """The name `make_rollout_backend` builds it from (one of ROLLOUT_BACKENDS)."""
    reward_threads: int = 1
    """Host threads the Controller may score a large batch's rewards on
    (core/rollouts/parallel_reward.py): 1, one plain call, unless the backend leaves the host's
    cores idle while it rolls out (the GPU backend)."""
    diverged: np.ndarray | bool = False
    """(num_rollouts,) True for each row of the last batch whose states went non-finite, for a
    backend that tracks it (a task's own dynamics, core/rollouts/dynamics.py); the Controller scores
    those rows -inf. False: none tracked."""

    @abc.abstractmethod
    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Roll out every control sequence from the same full-physics `initial_state` (nstate,).

        Args:
            initial_state: (nstate,) state as written by mj_getState with mjSTATE_FULLPHYSICS.
            controls: (num_rollouts, T, nu) C-contiguous float64 controls, one per step. After
                `set_models(models)`, num_rollouts is a multiple of len(models) and block r of the
                rows runs on models[r].
            mocap: (7 * nmocap,) [mocap_pos.ravel(), mocap_quat.ravel()] held through every rollout
                (mocap bodies are not part of the full-physics state); None keeps the model's
                defaults.
        Returns:
            states (num_rollouts, T, nstate) full-physics states after each step, and
            sensors (num_rollouts, T, nsensordata) sensor values after each step; both may be
            overwritten by the next call.
        """

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """Roll out later batches under several models (domain randomization), or under `model`
        alone (None).

        With R = len(models), a batch of M control rows (M a multiple of R) is split into R equal
        blocks in order: rows [r * M / R, (r + 1) * M / R) run on models[r]. The Controller passes
        each sampled sequence once per block, so rows r * N + i are sequence i under model r. The
        models must have the sizes of `model` (copies of it with other parameter values); they are
        kept by reference, not copied, until the next call.

        The default accepts only None or [model]; a backend that cannot roll out per-rollout models
        raises RandomizedRolloutError naming itself and the setting.
        """
        if models is None or (len(models) == 1 and models[0] is self.model):
            return
        raise RandomizedRolloutError(
            f"the {type(self).__name__} rollout backend cannot roll out under several "
            "models, so it cannot run "
            f"num_randomizations = {len(models)}; expected num_randomizations = 1 on this "
            "backend, or the cpu backend "
            "(RolloutPool), which can"
        )

    cancel: "CancelFlag | None" = None
    """Set by the Controller for one cycle, and None again once the cycle ends: a backend that can
    stop part-way through a batch polls it and raises PlanningCancelled once it is set; the default
    backend never looks. A plain attribute (a wrapping backend makes it a property that reaches its
    inner one), so a cycle runs no code here."""

    def set_cancel(self, cancel: "CancelFlag | None") -> None:
        """Poll `cancel` during the rollouts from now on (None: never): sets `cancel`."""
        self.cancel = cancel

    def close(self) -> None:  # noqa: B027  (no resources by default)
        """Release threads or device memory; the backend cannot be used afterwards."""

    def __enter__(self: BackendT) -> BackendT:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class PlanningCancelled(JudoError):
    """The `cancel` flag of `Controller.update_action` was set: the cycle stopped (between optimizer
    iterations, or part-way through a batch of rollouts whose outputs are then partial) and the
    previous plan stays."""


class RandomizedRolloutError(JudoError):
    """A rollout backend was asked to roll out under several models and cannot, or the models do not
    fit."""


MODEL_SIZES = ("nq", "nv", "nu", "na", "nmocap", "nsensordata")
"""The sizes every model given to `set_models` must share with the backend's model."""


def check_model_sizes(
    model: mujoco.MjModel, models: Sequence[mujoco.MjModel]
) -> list[mujoco.MjModel]:
    """`models` as a list, or RandomizedRolloutError for an empty list or a model whose MODEL_SIZES
    differ from `model`'s."""
    models = list(models)
    if not models:
        raise RandomizedRolloutError("set_models needs at least one model, got an empty list")
    for i, other in enumerate(models):
        for size in MODEL_SIZES:
            if getattr(other, size) != getattr(model, size):
                raise RandomizedRolloutError(
                    f"model {i} passed to set_models has {size}={getattr(other, size)}, expected "
                    f"{getattr(model, size)} as in the backend's model"
                )
    return models


def check_blocks(num_rollouts: int, num_models: int) -> None:
    """RandomizedRolloutError unless a batch of `num_rollouts` rows splits evenly over `num_models`
    models."""
    if num_rollouts % num_models:
        raise RandomizedRolloutError(
            f"a batch of {num_rollouts} rollouts cannot be split evenly over the "
            f"{num_models} models "
            "given to set_models; expected a multiple of the number of models"
        )


RolloutBackendName = Literal["cpu", "warp"]
ROLLOUT_BACKENDS: tuple[str, ...] = get_args(RolloutBackendName)
"""Names `make_rollout_backend` accepts: "cpu" is `RolloutPool`; "warp" is `WarpRollout` (MuJoCo
Warp on warp's default device, a GPU when there is one; needs the judo-mpc[warp] extra)."""


class RolloutLimits(Protocol):
    """Hard limits (`judo.safety.feasibility.RolloutScreen`): (R * N,) rewards, each rollout that
    crosses a limit scored below every feasible one, from (R * N, T, ...) states, sensors, controls
    and the (nu,) control served now."""

    def screen(
        self, rewards: Any, states: Any, sensors: Any, controls: Any, served: Any, num_models: int
    ) -> Any: ...
