"""`WarpRollout`: the rollout backend on MuJoCo Warp, for thousands of rollouts per planning cycle
on a GPU.

Every rollout is one MuJoCo Warp world; all N worlds step together. States and sensors come back in
the same layout as `RolloutPool`'s (full-physics states per mj_getState, float64), so tasks and the
Controller do not change. Physics runs in float32.

On a CUDA device the T-step rollout (set the initial state, then per step: load controls, step,
record) is captured once as a CUDA graph and replayed; it is captured again only when N, T or the
model change. Inputs go to the device once per call from pinned host memory, and states and sensors
come back once into preallocated pinned host arrays. On the CPU device (no GPU) the same kernels are
launched directly and the host arrays are the device arrays themselves.

Under `set_models` the fields in which the models differ are MuJoCo Warp's per-world model arrays
(see core/rollouts/warp_models.py), and `rollout_problems` rolls out several problems, each from its
own state, in one batch (core/rollouts/problem_batch.py). The kernels and the state layouts they
read and write are in core/rollouts/warp_kernels.py; what the overflow flags mean, in
core/rollouts/warp_overflow.py.

Importing this module imports warp and mujoco_warp (the `judo-mpc[warp]` extra);
`make_rollout_backend` (core/rollouts/backend.py) imports it only when the "warp" backend is asked
for.
"""

import os
import time
import warnings
from collections.abc import Sequence

import mujoco
import numpy as np

from judo.core.errors import JudoError, import_extra
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RolloutBackend, check_blocks, check_model_sizes
from judo.core.rollouts.warp_kernels import (
    EXTRA_SPEC,
    INITIAL_SPEC,
    broadcast_initial,
    load_controls,
    record_step,
)
from judo.core.rollouts.warp_models import probe_sizes, put_model, varying_fields
from judo.core.rollouts.warp_overflow import (
    CONSTRAINT_OVERFLOWS,
    CONTACT_OVERFLOWS,
    DROPPED,
    MAX_RESIZES,
    RolloutOverflowError,
    RolloutOverflowWarning,
)

FEATURE = "the warp rollout backend (--backend warp)"
wp = import_extra("warp", FEATURE, "warp")
mjw = import_extra("mujoco_warp", FEATURE, "warp")

__all__ = ["WarpRollout"]

PHASES = ("copy_in", "physics", "copy_out")
"""Where a rollout's wall time goes, summed over calls in `WarpRollout.phase_seconds`: inputs to the
device (host staging included), the T steps on the device, and states, sensors and overflow flags
back to the host."""


class WarpRollout(RolloutBackend):
    """Rolls out batches of control sequences as MuJoCo Warp worlds
    on `wp.get_device()` (or `device`).

    Contacts and constraint rows per world start at twice what MuJoCo finds at the model's reference
    pose, its keyframes and the first initial state (at least 64 contacts and 128 rows). A batch
    that overflows them is never returned: the overflowing buffer is doubled, a
    RolloutOverflowWarning says so, and the batch is rolled out again (RolloutOverflowError after
    MAX_RESIZES doublings). The grown sizes stay.

    Args:
        model: the planning model; WarpUnsupportedModelError if MuJoCo Warp cannot run it.
        device: a warp device ("cpu", "cuda:0"); the default device when None.
        deterministic: bitwise repeatable results on CUDA (stable contact order and atomics). Off by
            default: warp's deterministic launches allocate a sort workspace per launch, and inside
            the captured T-step graph these add up; on an H100 (80 GB) cartpole at N = 256 ran out
            of memory. Without it a seeded run on CUDA differs from run to run in float32's last
            digits; the CPU device is deterministic either way.
        nconmax, njmax: contacts and constraint rows per world to start from, instead of the sizes
            probed from the model (they still grow on overflow).
    """

    name = "warp"
    phase_seconds: dict[str, float]
    """Seconds spent in each of PHASES, summed over every call so far (benchmarks read and reset
    it)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        device: str | None = None,
        deterministic: bool = False,
        nconmax: int | None = None,
        njmax: int | None = None,
    ) -> None:
        self.model = model
        self.num_workers = 1
        # the host's cores are idle while the device rolls out
        self.reward_threads = os.cpu_count() or 1
        self.device = wp.get_device(device)
        self.deterministic = deterministic
        self._graph = None
        self._start_sizes = (nconmax, njmax)
        self.phase_seconds = dict.fromkeys(PHASES, 0.0)
        # set_models' models, or None for `model` alone
        self._models: list[mujoco.MjModel] | None = None
        # field name -> (R, *field shape) values that differ by model
        self._varying: dict[str, np.ndarray] = {}
        self._upload(model)

    def _upload(self, model: mujoco.MjModel, batch_sizes: dict[str, int] | None = None) -> None:
        """Put `model` on the device, with the fields in `batch_sizes` given one row per world;
        buffers are sized and allocated (and the graph captured) at the next call."""
        # a new model: its buffers are sized at the next call
        if getattr(self, "_uploaded", None) is not model:
            self.nconmax = self.njmax = 0
            self._sized = False
        with wp.ScopedDevice(self.device):
            self._device_model = put_model(model, self.deterministic, batch_sizes)
        self._uploaded = model
        self._batch_layout = (
            tuple(sorted(batch_sizes or {})),
            next(iter((batch_sizes or {0: 0}).values())),
        )
        self.nstate = mujoco.mj_stateSize(model, STATE_SPEC)
        self.nextra = mujoco.mj_stateSize(model, EXTRA_SPEC)
        self.ninitial = mujoco.mj_stateSize(model, INITIAL_SPEC)
        self._scratch = mujoco.MjData(model)
        self._default_mocap = np.concatenate(
            [self._scratch.mocap_pos.ravel(), self._scratch.mocap_quat.ravel()]
        )
        self._shape: tuple[int, int, int] | None = None
        # the (rows, problems) the batched fields were written for
        self._written: tuple[int, int] | None = None

    def set_models(self, models: Sequence[mujoco.MjModel] | None) -> None:
        """See `RolloutBackend.set_models`. The fields in which the models differ become per-world
        arrays of the device model (MuJoCo Warp's batched model fields); a later set of models that
        differs in the same fields is written into those arrays in place, so the captured graph
        stays valid. RandomizedRolloutError names a field that differs and that MuJoCo Warp cannot
        hold per world."""
        if models is None or (len(models) == 1 and models[0] is self.model):
            self._models, self._varying = None, {}
            return
        models = check_model_sizes(self.model, models)
        self._varying = varying_fields(self.model, models, self.deterministic)
        self._models, self._written = models, None

    def _write_model_values(self, num_rows: int, num_problems: int) -> None:
        """Each varying field's per-world values: problem p's block of rows, split into R equal
        blocks, block r on models[r]; written into the device arrays in place."""
        assert self._models is not None  # only called under set_models
        per_problem = num_rows // num_problems
        for name, values in self._varying.items():  # values: (R, *field shape)
            # (per_problem, *field shape)
            rows = np.repeat(values, per_problem // len(self._models), axis=0)
            getattr(self._device_model, name).assign(np.concatenate([rows] * num_problems))
        self._written = (num_rows, num_problems)

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """See `RolloutBackend.rollout`. Returns float64 (N, T, nstate) states and (N, T,
        nsensordata) sensors in preallocated host arrays, overwritten by the next call."""
        return self.rollout_problems(
            initial_state[None], controls, None if mocap is None else mocap[None]
        )

    def rollout_problems(
        self, initial_states: np.ndarray, controls: np.ndarray, mocaps: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Roll out P problems in one batch: problem p's rows [p * M, (p + 1) * M) start from
        initial_states[p].

        Args:
            initial_states: (P, nstate) full-physics states, one per problem.
            controls: (P * M, T, nu) C-contiguous float64 controls; under `set_models` each
                problem's M rows split into R equal blocks, block r on models[r].
            mocaps: (P, 7 * nmocap) each problem's mocap poses, or None for the model's defaults.
        Returns:
            states (P * M, T, nstate) and sensors (P * M, T, nsensordata) in preallocated host
            arrays, overwritten by the next call.
        """
        num_problems = len(initial_states)
        num_rollouts, num_steps, _ = controls.shape
        if num_rollouts % num_problems:
            raise JudoError(
                f"{num_rollouts} rows cannot be split evenly over {num_problems} problems"
            )
        if self._models is not None:
            check_blocks(num_rollouts // num_problems, len(self._models))
        # a row per world
        batch_sizes = dict.fromkeys(self._varying, num_rollouts) if self._models is not None else {}
        layout = tuple(sorted(batch_sizes)), num_rollouts if batch_sizes else 0
        # a new model or other batched fields
        if self.model is not self._uploaded or layout != self._batch_layout:
            self._upload(self.model, batch_sizes)
        with wp.ScopedDevice(self.device):
            if self._shape != (num_rollouts, num_steps, num_problems):
                if not self._sized:
                    self._size_buffers(initial_states[0])
                self._allocate(num_rollouts, num_steps, num_problems)
            if self._models is not None and self._written != (num_rollouts, num_problems):
                self._write_model_values(num_rollouts, num_problems)
            poses = [None] * num_problems if mocaps is None else list(mocaps)
            initial = np.stack(
                [self._initial_vector(s, m) for s, m in zip(initial_states, poses, strict=True)]
            )
            for _ in range(MAX_RESIZES):
                started = time.perf_counter()
                self._host_initial[:] = initial
                np.copyto(self._host_controls, controls)
                self.phase_seconds["copy_in"] += time.perf_counter() - started
                self._run()
                overflow = int(np.bitwise_or.reduce(self._host_overflow))
                if not overflow & DROPPED:
                    return self._host_states, self._host_sensors
                self._grow(overflow, int(np.count_nonzero(self._host_overflow & DROPPED)))
        raise RolloutOverflowError(
            f"MuJoCo Warp rollouts still overflow with {self.nconmax} contacts and "
            f"{self.njmax} constraint rows "
            f"per world after {MAX_RESIZES} doublings; expected a model whose contacts fit. "
            "Use --backend cpu."
        )

    def _initial_vector(self, initial_state: np.ndarray, mocap: np.ndarray | None) -> np.ndarray:
        """(ninitial,) INITIAL_SPEC vector: `initial_state`, a zero warm start, and `mocap` (or the
        defaults)."""
        data, model = self._scratch, self.model
        mujoco.mj_setState(model, data, initial_state, STATE_SPEC)
        data.qacc_warmstart[:] = 0.0
        poses = self._default_mocap if mocap is None else mocap
        data.mocap_pos[:] = poses[: 3 * model.nmocap].reshape(-1, 3)
        data.mocap_quat[:] = poses[3 * model.nmocap :].reshape(-1, 4)
        vector = np.empty(self.ninitial)
        mujoco.mj_getState(model, data, vector, INITIAL_SPEC)
        return vector

    def _run(self) -> None:
        """One rollout of the batch already in the host inputs; outputs and overflow flags land in
        the host arrays. Adds the time of each phase to `phase_seconds` (on CUDA, waiting for the
        device after each phase: the phases run one after the other on one stream anyway)."""
        seconds, clock = self.phase_seconds, time.perf_counter
        # host arrays are the device arrays: launch (synchronous on the CPU) and done
        if not self.device.is_cuda:
            started = clock()
            self._launch_rollout()
            seconds["physics"] += clock() - started
            return
        started = clock()
        wp.copy(self._initial, self._pinned_initial)
        wp.copy(self._controls, self._pinned_controls)
        wp.synchronize_device(self.device)
        copied = clock()
        if self._graph is None:
            self._launch_rollout()  # compiles and loads every kernel before the capture
            with wp.ScopedCapture(device=self.device) as capture:
                self._launch_rollout()
            self._graph = capture.graph
        wp.capture_launch(self._graph)
        wp.synchronize_device(self.device)
        stepped = clock()
        wp.copy(self._pinned_states, self._states)
        wp.copy(self._pinned_sensors, self._sensors)
        wp.copy(self._pinned_overflow, self._data.overflow)
        wp.synchronize_device(self.device)
        seconds["copy_in"] += copied - started
        seconds["physics"] += stepped - copied
        seconds["copy_out"] += clock() - stepped

    def _launch_rollout(self) -> None:
        """The T-step rollout on the device: reset overflow flags, start every world from the
        initial vector, then per step load the controls, step, and record state and sensors."""
        m, d = self._device_model, self._data
        assert self._shape is not None  # set with self._data by _allocate
        num_rollouts, num_steps, num_problems = self._shape
        d.overflow.zero_()
        inputs = [self._initial, num_rollouts // num_problems, self._start]
        wp.launch(broadcast_initial, dim=(num_rollouts, self.ninitial), inputs=inputs)
        mjw.set_state(m, d, self._start, int(INITIAL_SPEC))
        record_dim = (num_rollouts, self.nstate + self.model.nsensordata)
        for step in range(num_steps):
            if self.model.nu:
                wp.launch(
                    load_controls,
                    dim=(num_rollouts, self.model.nu),
                    inputs=[self._controls, step, d.ctrl],
                )
            mjw.step(m, d)
            if self.nextra:
                mjw.get_state(m, d, self._extra, int(EXTRA_SPEC))
            wp.launch(
                record_step,
                dim=record_dim,
                inputs=[
                    d.time,
                    d.qpos,
                    d.qvel,
                    d.act,
                    self._extra,
                    d.sensordata,
                    step,
                    self._states,
                    self._sensors,
                ],
            )

    # ---- buffers -------------------------------------------------------------------------------
    def _size_buffers(self, initial_state: np.ndarray) -> None:
        ncon, nefc = probe_sizes(self.model, [initial_state])
        nconmax, njmax = self._start_sizes
        self.nconmax = max(64, 2 * ncon) if nconmax is None else nconmax
        self.njmax = max(128, 2 * nefc) if njmax is None else njmax
        self._sized = True

    def _grow(self, overflow: int, worlds: int) -> None:
        """Double the buffer that overflowed, warn, and rebuild the device data (and graph) at the
        same N x T."""
        old = (self.nconmax, self.njmax)
        if overflow & CONTACT_OVERFLOWS:
            self.nconmax = max(1, 2 * self.nconmax)
        if overflow & CONSTRAINT_OVERFLOWS:
            self.njmax = max(1, 2 * self.njmax)
        names = [
            flag.name
            for flag in mjw.OverflowType
            if flag & DROPPED and flag & overflow and flag.name
        ]
        assert self._shape is not None  # _grow follows a rollout of the allocated batch
        warnings.warn(
            f"MuJoCo Warp rollouts overflowed ({', '.join(names)}) in {worlds} of "
            f"{self._shape[0]} worlds; "
            f"contacts per world {old[0]} -> {self.nconmax}, constraint rows {old[1]} -> "
            f"{self.njmax}; rolled out again",
            RolloutOverflowWarning,
            stacklevel=3,
        )
        self._allocate(*self._shape)

    def _allocate(self, num_rollouts: int, num_steps: int, num_problems: int = 1) -> None:
        """Device data for N worlds, device inputs and outputs, and their host mirrors (pinned on
        CUDA)."""
        self._shape, self._graph = (num_rollouts, num_steps, num_problems), None
        model, device = self.model, self.device
        self._data = mjw.make_data(
            model, nworld=num_rollouts, nconmax=self.nconmax, njmax=self.njmax
        )
        self._initial = wp.zeros((num_problems, self.ninitial), dtype=wp.float64, device=device)
        self._start = wp.zeros((num_rollouts, self.ninitial), dtype=wp.float32, device=device)
        self._extra = wp.zeros((num_rollouts, self.nextra), dtype=wp.float32, device=device)
        self._controls = wp.zeros(
            (num_rollouts, num_steps, model.nu), dtype=wp.float64, device=device
        )
        self._states = wp.zeros(
            (num_rollouts, num_steps, self.nstate), dtype=wp.float64, device=device
        )
        self._sensors = wp.zeros(
            (num_rollouts, num_steps, model.nsensordata), dtype=wp.float64, device=device
        )
        if device.is_cuda:
            pinned = {"device": "cpu", "pinned": True}
            self._pinned_initial = wp.zeros(self._initial.shape, dtype=wp.float64, **pinned)
            self._pinned_controls = wp.zeros(self._controls.shape, dtype=wp.float64, **pinned)
            self._pinned_states = wp.zeros(self._states.shape, dtype=wp.float64, **pinned)
            self._pinned_sensors = wp.zeros(self._sensors.shape, dtype=wp.float64, **pinned)
            self._pinned_overflow = wp.zeros(
                num_rollouts, dtype=self._data.overflow.dtype, **pinned
            )
            host = (
                self._pinned_initial,
                self._pinned_controls,
                self._pinned_states,
                self._pinned_sensors,
            )
            self._host_overflow = self._pinned_overflow.numpy()
        else:
            host = (self._initial, self._controls, self._states, self._sensors)
            self._host_overflow = self._data.overflow.numpy()
        self._host_initial, self._host_controls, self._host_states, self._host_sensors = (
            a.numpy() for a in host
        )

    def close(self) -> None:
        """Free the device buffers, the pinned host buffers and the graph (a later call allocates
        them again)."""
        self._graph, self._shape = None, None
        buffers = ("_data", "_initial", "_start", "_extra", "_controls", "_states", "_sensors")
        for name in [
            key for key in vars(self) if key in buffers or key.startswith(("_pinned_", "_host_"))
        ]:
            delattr(self, name)
