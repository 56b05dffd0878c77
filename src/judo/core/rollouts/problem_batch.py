"""`ProblemBatch`: P controllers' rollouts as one batch of one backend (P problems x N rollouts per
launch).

On a GPU a rollout of 1024 worlds costs little more than one of 256: the kernel chain, not the
worlds, sets the time. Several closed-loop episodes (evaluate's seeds) therefore run faster side by
side in one process, their planning cycles in lockstep, than one after the other. Each episode's
Controller rolls out on its own `ProblemSlot`, a RolloutBackend; a slot's `rollout` waits until
every open slot has handed in its batch, and the last to arrive rolls out all of them in one
`rollout_problems` call of the shared backend (problem p's rows start from its own state and mocap
poses), then every slot gets its own rows back.

A slot that closes (its episode ended or failed) no longer holds the others up. Every open slot must
roll out batches of the same N x T (the same configs); a slot that differs raises ProblemBatchError
rather than waiting forever. Randomized models (`set_models`) are refused: the shared backend holds
one set of models.
"""

import threading
from collections.abc import Sequence
from typing import Protocol, cast

import mujoco
import numpy as np

from judo.core.errors import JudoError
from judo.core.rollouts.backend import RolloutBackend


class ProblemBackend(Protocol):
    """A backend that rolls out several problems in one batch (`WarpRollout`)."""

    model: mujoco.MjModel
    name: str

    def rollout_problems(
        self, initial_states: np.ndarray, controls: np.ndarray, mocaps: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def close(self) -> None: ...


class ProblemBatchError(JudoError):
    """The open slots of a ProblemBatch asked for batches of different shapes, or a rollout of the
    batch failed."""


class ProblemBatch:
    """One shared backend, and `num_problems` slots that roll out on it together.

    Args:
        backend: rolls out the combined batch; owned here (closed by `close`).
        num_problems: the slots, P.
        timeout: most seconds a slot waits for the others before ProblemBatchError (a stuck
            episode).
    """

    def __init__(self, backend: ProblemBackend, num_problems: int, timeout: float = 600.0) -> None:
        self.backend = backend
        self.timeout = timeout
        self.slots = [ProblemSlot(self, p) for p in range(num_problems)]
        self._lock = threading.Condition()
        self._open = set(range(num_problems))
        self._inputs: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        self._results: dict[int, tuple[np.ndarray, np.ndarray] | BaseException] = {}
        self._round = 0
        self.launches = 0
        """Combined rollouts so far."""

    def _submit(
        self, p: int, initial: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None
    ) -> tuple:
        """Hand in slot p's batch; return its rows of the combined rollout once every open slot has
        handed in."""
        with self._lock:
            self._inputs[p] = (initial, controls, mocap)
            this_round = self._round
            self._launch_if_complete()
            if not self._lock.wait_for(lambda: self._round != this_round, timeout=self.timeout):
                self._inputs.pop(p, None)
                raise ProblemBatchError(
                    f"problem {p} waited {self.timeout:g} s for the other problems' batches; slots "
                    f"{sorted(self._open - set(self._inputs))} never handed theirs in"
                )
            result = self._results.pop(p)
        if isinstance(result, BaseException):
            raise result
        return result

    def _close_slot(self, p: int) -> None:
        with self._lock:
            self._open.discard(p)
            self._inputs.pop(p, None)
            self._launch_if_complete()

    def _launch_if_complete(self) -> None:
        """With the lock held: when every open slot has handed in, roll them out as one batch and
        wake them."""
        if not self._inputs or set(self._inputs) != self._open:
            return
        order = sorted(self._inputs)
        inputs = [self._inputs[p] for p in order]
        shapes = {controls.shape for _, controls, _ in inputs}
        try:
            if len(shapes) > 1:
                raise ProblemBatchError(
                    "the problems of one batch must roll out batches of one N x T x nu, got "
                    f"{sorted(shapes)}; "
                    "expected every episode to run the same configs"
                )
            initial = np.stack([state for state, _, _ in inputs])
            controls = np.concatenate([c for _, c, _ in inputs])
            mocaps = (
                None
                if inputs[0][2] is None
                else np.stack([cast(np.ndarray, m) for _, _, m in inputs])
            )
            states, sensors = self.backend.rollout_problems(initial, controls, mocaps)
            rows = len(inputs[0][1])
            for i, p in enumerate(order):
                self._results[p] = (
                    states[i * rows : (i + 1) * rows],
                    sensors[i * rows : (i + 1) * rows],
                )
            self.launches += 1
        except Exception as err:  # every waiting slot gets the failure, then raises it
            for p in order:
                self._results[p] = err
        self._inputs.clear()
        self._round += 1
        self._lock.notify_all()

    def close(self) -> None:
        """Close every slot and the shared backend."""
        for slot in self.slots:
            slot.close()
        self.backend.close()


class ProblemSlot(RolloutBackend):
    """Problem p's view of a ProblemBatch: a RolloutBackend whose rollouts are rows of the batch's
    combined one.

    The arrays it returns belong to the shared backend's host buffers and are overwritten by the
    next combined rollout, as a plain backend's are by its next call.
    """

    def __init__(self, batch: ProblemBatch, index: int) -> None:
        self.batch = batch
        self.index = index
        self.model = batch.backend.model
        self.name = batch.backend.name
        self.num_workers = 1
        self.reward_threads = 1  # P episodes score their rewards side by side on the host already
        self._closed = False

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """See `RolloutBackend.rollout`; waits for the other open slots' batches."""
        if self._closed:
            raise ProblemBatchError(f"problem slot {self.index} is closed")
        return self.batch._submit(self.index, initial_state, controls, mocap)

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """Only the shared model: a problem batch rolls out without randomized models."""
        if models is None or (len(models) == 1 and models[0] is self.model):
            return
        raise ProblemBatchError(
            "episodes batched as problems on one backend cannot roll out under "
            f"{len(models)} randomized models; "
            "expected num_randomizations = 1, or one episode per batch"
        )

    def close(self) -> None:
        """Leave the batch: the other slots no longer wait for this one."""
        if not self._closed:
            self._closed = True
            self.batch._close_slot(self.index)
