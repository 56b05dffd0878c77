"""`PolicyStepper`: a batch of MuJoCo states stepped with a policy acting between physics ticks,
written once.

Every tick of k physics steps, each block of rows (a worker's share of the batch, or the whole
batch) makes its (B, O) observations from the rows' states at the tick, one batched `act` gives each
row an action (or a chunk of H, read off its spline at each of the tick's steps), the ctrl of the
tick's steps is written into the inputs of `mujoco.rollout`, and the physics steps every row on from
its own state. Four places run it:
  - `LowLevelRollout` (core/rollouts/low_level_rollout.py): a task's low-level policy inside every
    rollout, block by block on a `RolloutPool`'s workers (`run_blocks`);
  - `LowLevelPlant` (core/rollouts/low_level.py): the same policy on the plant, one row, whose
    physics is the plant's own steps (`act` alone makes each tick's ctrl);
  - `Proposer` (core/policies/proposals.py): an action policy's closed loop from the current state,
    one step per tick;
  - `GaitEpisodes` (learning/policy_search.py): every candidate gait policy on its own commands,
    block by block.
Buffers are allocated per (N, T) and reused; a block reads and writes only its own rows of them, so
blocks run on several threads at once.
"""

import math
from collections.abc import Callable

import mujoco
import numpy as np

from judo.core.model import STATE_SPEC
from judo.core.rollouts.rollout import MOCAP_CONTROL_SPEC, RolloutPool

Observe = Callable[[slice, int, np.ndarray, np.ndarray], np.ndarray]
"""(rows, the tick's first step, the rows' (B, nstate) states at the tick, their (B, A) previous
actions) -> (B, O)."""
Act = Callable[[slice, np.ndarray], np.ndarray]
"""(rows, (B, O) observations) -> (B, H, A) actions: one batched policy call."""
Physics = Callable[[np.ndarray, np.ndarray, int, np.ndarray, np.ndarray], None]
"""(initial states (N, nstate), inputs (N, n, ninputs), control spec, states (N, n, nstate), sensors
(N, n, nsensordata)): steps the block's rows n steps on from their initial states, writing only
those rows."""
Record = Callable[[slice, int, int], None]
"""(rows, the tick's first step, its stop): called after each tick's physics, to keep what the tick
reached."""


class PolicyStepper:
    """Steps N rows of `model` through ticks of `every` physics steps, one batched policy call per
    tick and block.

    Args:
        model: the model stepped (its sizes; the physics callable may step perturbed copies of it).
        action_size: A, the width of the policy's actions.
        every: k, physics steps per tick (the last tick of a run may be shorter).
        step_weights: n -> (n, H) the weights that give each of a tick's n steps its action from the
            H actions of one `act` (a chunk's spline at 0, dt, 2 dt, ...); None: the one action (H =
            1) is held for the tick.
        to_ctrl: (M, A) actions -> (M, nu) ctrl; None: the actions are the ctrl.

    Attributes (what a block reads and writes is its rows of each):
        current: (N, nstate) each row's full-physics state at the tick.
        previous: (N, A) each row's actions of the last tick, the last step's for a chunk (zeros at
            the start).
        finite: (N,) False for a row the policy gave a non-finite action (only `run` checks; see
            `act`).
        observations: (N, O) a buffer an `observe` may write into and return (O from
            `observation_size`).
        inputs, states, sensors: {n: (N, n, ...)} for each tick length n: the per-step [ctrl] or
            [ctrl, mocap_pos, mocap_quat] that `mujoco.rollout` takes, and the (nstate) states and
            (nsensordata) sensors the steps reach.
        ticks: [(start, stop)] the steps of each tick of a run.
        control_spec: the inputs' mjtState spec: ctrl, with the mocap poses where `start` was given
            them.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        action_size: int,
        every: int = 1,
        step_weights: Callable[[int], np.ndarray] | None = None,
        to_ctrl: Callable[[np.ndarray], np.ndarray] | None = None,
        observation_size: int = 0,
    ) -> None:
        self.model, self.action_size, self.every = model, action_size, every
        self.step_weights, self.to_ctrl, self.observation_size = (
            step_weights,
            to_ctrl,
            observation_size,
        )
        self.nstate = mujoco.mj_stateSize(model, STATE_SPEC)
        self.control_spec = int(mujoco.mjtState.mjSTATE_CTRL)
        self._key: tuple[int, int, bool] | None = None

    def start(
        self,
        num_rows: int,
        num_steps: int,
        initial_states: np.ndarray,
        mocap: np.ndarray | None = None,
    ) -> None:
        """Begin a run of `num_steps` steps of `num_rows` rows from `initial_states` ((nstate,) for
        every row, or (N, nstate)), with the (7 nmocap,) `mocap` poses held as inputs where given
        (MuJoCo's rollout resets them to the model's otherwise): previous actions zero, every row
        finite. Buffers are reallocated only when N, T or the inputs' layout change."""
        with_mocap = mocap is not None and self.model.nmocap > 0
        if self._key != (num_rows, num_steps, with_mocap):
            self._allocate(num_rows, num_steps, with_mocap)
        self.control_spec = int(MOCAP_CONTROL_SPEC if with_mocap else mujoco.mjtState.mjSTATE_CTRL)
        if with_mocap:
            for inputs in self.inputs.values():
                inputs[..., self.model.nu :] = mocap
        self.current[:] = initial_states
        self.previous[:] = 0.0
        self.finite[:] = True

    def _allocate(self, num_rows: int, num_steps: int, with_mocap: bool) -> None:
        model, k = self.model, self.every
        width = model.nu + (7 * model.nmocap if with_mocap else 0)
        self._key = (num_rows, num_steps, with_mocap)
        self.current = np.zeros((num_rows, self.nstate))
        self.previous = np.zeros((num_rows, self.action_size))
        self.finite = np.ones(num_rows, dtype=bool)
        self.observations = np.zeros((num_rows, self.observation_size))
        self.ticks = [(t, min(t + k, num_steps)) for t in range(0, num_steps, k)]
        lengths = {stop - start for start, stop in self.ticks}
        self._weights = {
            n: None if self.step_weights is None else self.step_weights(n) for n in lengths
        }
        self.inputs = {n: np.zeros((num_rows, n, width)) for n in lengths}
        self.states = {n: np.zeros((num_rows, n, self.nstate)) for n in lengths}
        self.sensors = {n: np.zeros((num_rows, n, model.nsensordata)) for n in lengths}

    def act(self, rows: slice, chunk: np.ndarray, num_steps: int) -> np.ndarray:
        """Turn the (B, H, A) actions of one `act` for `rows` into the ctrl of a tick of `num_steps`
        steps (held, or each step's off the chunk's spline), written into those rows of
        `inputs[num_steps]`, and keep the last step's actions as the rows' `previous`; returns the
        rows' (B, num_steps, nu) ctrl (a view)."""
        ctrl = self.inputs[num_steps][rows, :, : self.model.nu]
        self._write_ctrl(chunk, self.previous[rows], ctrl, self._weights[num_steps])
        return ctrl

    def _write_ctrl(
        self, chunk: np.ndarray, previous: np.ndarray, ctrl: np.ndarray, weights: np.ndarray | None
    ) -> None:
        """`act` on the rows' (B, A) `previous` and (B, n, nu) `ctrl` views."""
        if weights is None:  # one action, held for the tick
            previous[:] = chunk[:, 0]
            if self.to_ctrl is None:
                ctrl[:] = previous[:, None, :]
            else:
                ctrl[:] = self.to_ctrl(chunk[:, 0])[:, None, :]
        else:  # each step's action off the chunk's spline
            actions = np.einsum("sh,bha->bsa", weights, chunk)
            previous[:] = actions[:, -1]
            flat = actions.reshape(-1, actions.shape[-1])
            ctrl[:] = (flat if self.to_ctrl is None else self.to_ctrl(flat)).reshape(
                len(chunk), -1, ctrl.shape[-1]
            )

    def run(
        self,
        rows: slice,
        observe: Observe,
        act: Act,
        physics: Physics,
        record: Record | None = None,
    ) -> None:
        """Every tick of the rows `rows` (one block), on the calling thread: their (B, O)
        observations, one batched `act`, the tick's ctrl, then `physics` steps them on from
        `current`, which then holds the last step's states. A row whose actions are not finite is
        marked in `finite` and steps on regardless.

        The block's views of the buffers are taken once per run, so that a tick's own Python (which
        holds the GIL while the other blocks' physics runs without it) is the observation, `act` and
        two small copies."""
        # views
        current, previous, finite = self.current[rows], self.previous[rows], self.finite[rows]
        nu, spec, everything = self.model.nu, self.control_spec, self.current
        # per tick length n: the tick's buffers, the block's ctrl in them and its last step's states
        views = {
            n: (
                self.inputs[n],
                self.states[n],
                self.sensors[n],
                self.inputs[n][rows, :, :nu],
                self.states[n][rows, -1],
            )
            for n in self.inputs
        }
        weights, write = self._weights, self._write_ctrl
        for start, stop in self.ticks:
            n = stop - start
            inputs, states, sensors, ctrl, last = views[n]
            chunk = act(rows, observe(rows, start, current, previous))
            # one cheap reduction per tick; rows only when it fails
            if not math.isfinite(chunk.sum()):
                finite &= np.isfinite(chunk).all(axis=(1, 2))
            write(chunk, previous, ctrl, weights[n])
            physics(everything, inputs, spec, states, sensors)
            current[:] = last
            if record is not None:
                record(rows, start, stop)

    def run_blocks(
        self, pool: RolloutPool, observe: Observe, act: Act, record: Record | None = None
    ) -> int:
        """`run` each of `pool`'s blocks of rows on its worker (the calling thread takes the first),
        each block's physics on its own MjData; returns the number of blocks (one `act` per tick
        each)."""
        blocks = pool.blocks(len(self.current))

        def roll(block: int) -> None:
            def physics(
                initial: np.ndarray,
                inputs: np.ndarray,
                spec: int,
                states: np.ndarray,
                sensors: np.ndarray,
            ):
                pool.rollout_block(block, initial, inputs, spec, states, sensors)

            self.run(blocks[block], observe, act, physics, record)

        pool.for_each_block(len(self.current), roll)
        return len(blocks)
