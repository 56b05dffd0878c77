"""Rollout backends: the one call the Controller makes, from one initial state and per-step controls
to per-step states and sensor values.

`RolloutPool` is the CPU backend: one shared MjModel, one MjData per worker thread, one C call per
chunk. Other backends (MuJoCo Warp on a GPU) implement the same `RolloutBackend` interface, so the
Controller's loop stays written once.
"""

import abc
import os
from collections.abc import Sequence
from typing import Literal, get_args

import mujoco
import mujoco.rollout
import numpy as np

from judo.core.errors import JudoError, UnknownNameError
from judo.core.model import STATE_SPEC
from judo.core.workers import DaemonThreadPool

MOCAP_CONTROL_SPEC = (
    mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_MOCAP_POS | mujoco.mjtState.mjSTATE_MOCAP_QUAT
)
"""Per-step inputs of a rollout on a model with mocap bodies: [ctrl, mocap_pos, mocap_quat]. MuJoCo's
rollout resets mocap poses to the model's defaults unless they are passed as inputs like this."""


CLOSE_TIMEOUT = 0.5
"""Most seconds `RolloutPool.close` waits for its workers."""


class RolloutBackend(abc.ABC):
    """Rolls out a batch of control sequences from one initial state.

    Attributes:
        model: the planning model every rollout runs on.
        num_workers: host threads the backend rolls out on (1 for a GPU backend).
        gui_max_rollouts: upper end of the GUI's num_rollouts slider on this backend; None keeps the
            optimizer config's own range.
    """

    model: mujoco.MjModel
    num_workers: int
    gui_max_rollouts: int | None = None

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
                (mocap bodies are not part of the full-physics state); None keeps the model's defaults.
        Returns:
            states (num_rollouts, T, nstate) full-physics states after each step, and
            sensors (num_rollouts, T, nsensordata) sensor values after each step; both may be
            overwritten by the next call.
        """

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """Roll out later batches under several models (domain randomization), or under `model` alone (None).

        With R = len(models), a batch of M control rows (M a multiple of R) is split into R equal
        blocks in order: rows [r * M / R, (r + 1) * M / R) run on models[r]. The Controller passes each
        sampled sequence once per block, so rows r * N + i are sequence i under model r. The models
        must have the sizes of `model` (copies of it with other parameter values); they are kept by
        reference, not copied, until the next call.

        The default accepts only None or [model]; a backend that cannot roll out per-rollout models
        raises RandomizedRolloutError naming itself and the setting.
        """
        if models is None or (len(models) == 1 and models[0] is self.model):
            return
        raise RandomizedRolloutError(
            f"the {type(self).__name__} rollout backend cannot roll out under several models, so it cannot run "
            f"num_randomizations = {len(models)}; expected num_randomizations = 1 on this backend, or the cpu backend "
            "(RolloutPool), which can"
        )

    def close(self) -> None:  # noqa: B027  (no resources by default)
        """Release threads or device memory; the backend cannot be used afterwards."""


class RandomizedRolloutError(JudoError):
    """A rollout backend was asked to roll out under several models and cannot, or the models do not fit."""


class RolloutPool(RolloutBackend):
    """Rolls out batches of control sequences from one initial state on `num_workers` threads.

    The batch is split into one contiguous chunk per worker; each worker runs MuJoCo's C rollout on
    its own MjData with the GIL released. Output buffers, and each chunk's list of per-rollout models,
    are built when the batch shape or the models change and reused otherwise, so the returned arrays
    are overwritten by the next call. Under `set_models` MuJoCo's rollout gets the mixed list of
    models, by reference: nothing is copied per call.
    """

    def __init__(self, model: mujoco.MjModel, num_workers: int | None = None) -> None:
        self.model = model
        self.num_workers = max(1, num_workers or os.cpu_count() or 1)
        self.nstate = mujoco.mj_stateSize(model, STATE_SPEC)
        self._datas = [mujoco.MjData(model) for _ in range(self.num_workers)]
        self._runners = [mujoco.rollout.Rollout(nthread=0) for _ in range(self.num_workers)]
        self._executor = DaemonThreadPool(self.num_workers, "judo-rollout")
        self._shape: tuple[int, int] | None = None
        self._models: list[mujoco.MjModel] = [model]

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """See `RolloutBackend.set_models`; raises RandomizedRolloutError for a model of other sizes."""
        models = [self.model] if models is None else list(models)
        if not models:
            raise RandomizedRolloutError("set_models needs at least one model, got an empty list")
        for i, other in enumerate(models):
            for size in ("nq", "nv", "nu", "na", "nmocap", "nsensordata"):
                if getattr(other, size) != getattr(self.model, size):
                    raise RandomizedRolloutError(
                        f"model {i} passed to set_models has {size}={getattr(other, size)}, expected "
                        f"{getattr(self.model, size)} as in the pool's model"
                    )
        self._models = models
        self._shape = None  # rebuild the chunks' model lists on the next rollout

    def _allocate(self, num_rollouts: int, num_steps: int) -> None:
        self._shape = (num_rollouts, num_steps)
        self._initial = np.zeros((num_rollouts, self.nstate))
        self._states = np.zeros((num_rollouts, num_steps, self.nstate))
        self._sensors = np.zeros((num_rollouts, num_steps, self.model.nsensordata))
        self._inputs = np.zeros((num_rollouts, num_steps, self.model.nu + 7 * self.model.nmocap))
        bounds = np.linspace(0, num_rollouts, min(self.num_workers, num_rollouts) + 1).astype(int)
        self._chunks = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        block = num_rollouts // len(self._models)
        row_models = [model for model in self._models for _ in range(block)]  # block r: models[r]
        self._chunk_models = [row_models[c] for c in self._chunks]

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """See `RolloutBackend.rollout`; the work is split into one contiguous chunk per worker thread."""
        num_rollouts, num_steps, _ = controls.shape
        if num_rollouts % len(self._models):
            raise RandomizedRolloutError(
                f"a batch of {num_rollouts} rollouts cannot be split evenly over the {len(self._models)} models "
                "given to set_models; expected a multiple of the number of models"
            )
        if self._shape != (num_rollouts, num_steps):
            self._allocate(num_rollouts, num_steps)
        self._initial[:] = initial_state
        spec = mujoco.mjtState.mjSTATE_CTRL
        if mocap is not None and self.model.nmocap:
            self._inputs[..., : self.model.nu] = controls
            self._inputs[..., self.model.nu :] = mocap
            controls, spec = self._inputs, MOCAP_CONTROL_SPEC
        if len(self._chunks) == 1:
            self._run_chunk(0, controls, spec)
        else:
            futures = [self._executor.submit(self._run_chunk, i, controls, spec) for i in range(len(self._chunks))]
            for future in futures:
                future.result()
        return self._states, self._sensors

    def _run_chunk(self, worker: int, controls: np.ndarray, control_spec: int) -> None:
        chunk = self._chunks[worker]
        self._runners[worker].rollout(
            self._chunk_models[worker],
            [self._datas[worker]],
            self._initial[chunk],
            controls[chunk],
            control_spec=control_spec,
            skip_checks=True,
            nstep=controls.shape[1],
            state=self._states[chunk],
            sensordata=self._sensors[chunk],
        )

    def close(self) -> None:
        """Stop the worker threads; the pool cannot be used afterwards.

        Waits at most CLOSE_TIMEOUT seconds: a worker still inside a long rollout ends when it
        returns (the workers are daemon threads, so it never holds up the process's exit)."""
        self._executor.shutdown(wait=True, timeout=CLOSE_TIMEOUT)


RolloutBackendName = Literal["cpu", "warp"]
ROLLOUT_BACKENDS: tuple[str, ...] = get_args(RolloutBackendName)
"""Names `make_rollout_backend` accepts: "cpu" is `RolloutPool`; "warp" is `WarpRollout` (MuJoCo Warp on
warp's default device, a GPU when there is one; needs the judo[warp] extra)."""


def check_rollout_backend(name: str) -> None:
    """Raise UnknownNameError for a name not in ROLLOUT_BACKENDS, and MissingExtraError when the backend's
    optional extra is not installed; builds nothing."""
    if name not in ROLLOUT_BACKENDS:
        raise UnknownNameError("rollout backend", name, ROLLOUT_BACKENDS)
    if name == "warp":
        import judo.core.warp_rollout  # noqa: F401  (imports warp and mujoco_warp, or names the extra)


def make_rollout_backend(name: str, model: mujoco.MjModel, num_workers: int | None = None) -> RolloutBackend:
    """The rollout backend called `name` (one of ROLLOUT_BACKENDS) for `model`.

    `num_workers` sets the CPU pool's threads (one per core by default). Raises UnknownNameError for
    an unknown name, MissingExtraError when "warp" is asked for without the judo[warp] extra, and
    WarpUnsupportedModelError for a model MuJoCo Warp cannot run.
    """
    check_rollout_backend(name)
    if name == "warp":
        from judo.core.warp_rollout import WarpRollout

        return WarpRollout(model, num_workers)
    return RolloutPool(model, num_workers)
