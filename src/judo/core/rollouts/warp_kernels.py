"""The device side of a `WarpRollout` (core/rollouts/warp_rollout.py): the state layouts it starts
each world from and reads back, and the warp kernels that start the worlds, load each step's
controls and record each step's states and sensors.

Importing this module imports warp and mujoco_warp (the `judo-mpc[warp]` extra).
"""

from typing import TYPE_CHECKING, Any

import mujoco

from judo.core.errors import import_extra
from judo.core.model import STATE_SPEC

FEATURE = "the warp rollout backend (--backend warp)"
wp = import_extra("warp", FEATURE, "warp")

# warp's array types are call expressions, which a type checker cannot read as annotations
if TYPE_CHECKING:
    Float32Array = Any
    Float32Array2D = Any
    Float64Array2D = Any
    Float64Array3D = Any
else:  # the kernel argument types warp compiles the kernels below for
    Float32Array = wp.array(dtype=wp.float32)
    Float32Array2D = wp.array2d(dtype=wp.float32)
    Float64Array2D = wp.array2d(dtype=wp.float64)
    Float64Array3D = wp.array3d(dtype=wp.float64)

EXTRA_SPEC = STATE_SPEC & ~(
    mujoco.mjtState.mjSTATE_TIME
    | mujoco.mjtState.mjSTATE_QPOS
    | mujoco.mjtState.mjSTATE_QVEL
    | mujoco.mjtState.mjSTATE_ACT
)
"""The full-physics state after [time, qpos, qvel, act] (delay history, plugin and plastic state):
empty for most models; read with mjw.get_state each step when not."""
INITIAL_SPEC = (
    STATE_SPEC
    | mujoco.mjtState.mjSTATE_WARMSTART
    | mujoco.mjtState.mjSTATE_MOCAP_POS
    | mujoco.mjtState.mjSTATE_MOCAP_QUAT
)
"""What each rollout starts from: the full-physics state, a zero solver warm start (so a rollout
does not depend on the one before it) and the mocap poses, which then stay put for the whole
rollout."""


@wp.kernel
def broadcast_initial(initial: Float64Array2D, rows_per_problem: int, out: Float32Array2D):
    """out[world, i] = initial[world // rows_per_problem, i]: each block of rows_per_problem worlds
    starts from its problem's (ninitial,) state. Launch dim (N, ninitial)."""
    world, i = wp.tid()
    out[world, i] = wp.float32(initial[world // rows_per_problem, i])


@wp.kernel
def load_controls(
    controls: Float64Array3D,
    step: int,
    ctrl: Float32Array2D,
):
    """ctrl[world, j] = controls[world, step, j], the (N, nu) controls of one step. Launch dim (N,
    nu)."""
    world, j = wp.tid()
    ctrl[world, j] = wp.float32(controls[world, step, j])


@wp.kernel
def record_step(
    time: Float32Array,
    qpos: Float32Array2D,
    qvel: Float32Array2D,
    act: Float32Array2D,
    extra: Float32Array2D,
    sensordata: Float32Array2D,
    step: int,
    states: Float64Array3D,
    sensors: Float64Array3D,
):
    """states[:, step] = [time, qpos, qvel, act, extra] (N, nstate), the full-physics state in
    mj_getState's order, and sensors[:, step] = sensordata (N, nsensordata), as float64. Launch dim
    (N, nstate + nsensordata)."""
    world, i = wp.tid()
    nq, nv, na = qpos.shape[1], qvel.shape[1], act.shape[1]
    nstate = 1 + nq + nv + na + extra.shape[1]
    if i == 0:
        states[world, step, 0] = wp.float64(time[world])
    elif i < 1 + nq:
        states[world, step, i] = wp.float64(qpos[world, i - 1])
    elif i < 1 + nq + nv:
        states[world, step, i] = wp.float64(qvel[world, i - 1 - nq])
    elif i < 1 + nq + nv + na:
        states[world, step, i] = wp.float64(act[world, i - 1 - nq - nv])
    elif i < nstate:
        states[world, step, i] = wp.float64(extra[world, i - 1 - nq - nv - na])
    else:
        sensors[world, step, i - nstate] = wp.float64(sensordata[world, i - nstate])
