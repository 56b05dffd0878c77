"""LQR cost-to-go around a model's rest pose: the balance term of underactuated swing-up tasks.

A short sampling horizon cannot tell a state it can still bring back to upright from one it cannot,
and it cannot see the manoeuvre that recentres a balanced cart. The infinite-horizon LQR cost-to-go
x^T P x ranks states near the top by exactly that. Far from the top the linearisation means nothing,
so `capped_cost_to_go` saturates it at 1.
"""

from collections.abc import Sequence

import mujoco
import numpy as np

from judo.core.norms import wrap_angle

MAX_RICCATI_ITERATIONS = 100_000


def lqr_cost_to_go(
    model: mujoco.MjModel, state_weights: np.ndarray, control_weight: float
) -> np.ndarray:
    """(2 nv, 2 nv) matrix P of the infinite-horizon discrete LQR cost-to-go x^T P x around `model`
    resting in its default pose (qpos0, zero velocity and controls), for per-step costs x^T
    diag(state_weights) x + control_weight ||u||^2 on the model linearised there. x is [qpos -
    qpos0, qvel] (2 nv,).

    Only for models whose joints are hinges and slides (nq == nv), so that a state's deviation is a
    plain difference. Raises ValueError otherwise, or when the Riccati iteration does not converge
    (a rest pose the actuators cannot stabilise).
    """
    if model.nq != model.nv or model.na:
        raise ValueError(
            f"lqr_cost_to_go needs a model of hinge and slide joints without actuator states "
            f"(nq == nv, na == 0); this one has nq={model.nq}, nv={model.nv}, na={model.na}"
        )
    state_weights = np.asarray(state_weights, dtype=float)
    if state_weights.shape != (2 * model.nv,):
        raise ValueError(
            f"state_weights must have 2 * nv = {2 * model.nv} entries, got shape "
            f"{state_weights.shape}"
        )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    a, b = np.zeros((2 * model.nv, 2 * model.nv)), np.zeros((2 * model.nv, model.nu))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, a, b, None, None)
    q, r = np.diag(state_weights), control_weight * np.eye(model.nu)
    p = q
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(MAX_RICCATI_ITERATIONS):
            gain = np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
            updated = q + a.T @ p @ (a - b @ gain)
            if not np.isfinite(updated).all():
                break
            if np.allclose(updated, p, rtol=1e-10, atol=0.0):
                return 0.5 * (updated + updated.T)
            p = updated
    raise ValueError(
        f"the LQR Riccati iteration diverged or did not converge in {MAX_RICCATI_ITERATIONS} "
        "steps: "
        "the model's actuators cannot stabilise its rest pose"
    )


def capped_cost_to_go(
    deviations: np.ndarray, matrix: np.ndarray, saturation: float, angle_columns: Sequence[int] = ()
) -> np.ndarray:
    """(...) cost x^T P x / saturation, capped at 1, of (..., n) state deviations x with (n, n) P =
    `matrix`.

    0 at the rest pose; 1 for every state whose cost-to-go exceeds `saturation`, which should sit
    near the largest cost-to-go the real (saturating) actuators still recover from. The
    `angle_columns` of x belong to joints that turn freely: they are wrapped to [-pi, pi) first, so
    a full turn counts as no deviation.
    """
    if len(angle_columns):
        deviations = deviations.copy()
        deviations[..., angle_columns] = wrap_angle(deviations[..., angle_columns])
    return np.minimum(
        np.einsum("...i,ij,...j->...", deviations, matrix, deviations) / saturation, 1.0
    )
