"""Tangent-space arithmetic on MuJoCo states and sensor residuals, for filters whose covariance is 2
nv + na wide.

A state x is [qpos (nq,), qvel (nv,), act (na,)]; a tangent vector dx is [dq (nv,), dv (nv,), da
(na,)], with dq a velocity integrated over one second (`mj_integratePos`), so a free joint's
quaternion stays on the unit sphere and its covariance is 3 x 3, not 4 x 4.
"""

import mujoco
import numpy as np

from judo.core.sensors import QUATERNION_TYPES, MeasuredLayout


class TangentSpace:
    """`plus` and `minus` for the states of `model`."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.nq, self.nv, self.na = model.nq, model.nv, model.na
        self.size = 2 * model.nv + model.na
        """2 nv + na, the length of a tangent vector."""

    def plus(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """(nq + nv + na,) the state `x` moved by the (size,) tangent vector `dx`."""
        nq, nv = self.nq, self.nv
        out = x.copy()
        mujoco.mj_integratePos(self.model, out[:nq], dx[:nv], 1.0)
        out[nq:] += dx[nv:]
        return out

    def minus(self, x: np.ndarray, base: np.ndarray) -> np.ndarray:
        """(size,) the tangent vector dx with `plus(base, dx) == x`."""
        nq, nv = self.nq, self.nv
        dx = np.empty(self.size)
        mujoco.mj_differentiatePos(self.model, dx[:nv], 1.0, base[:nq], x[:nq])
        dx[nv:] = x[nq:] - base[nq:]
        return dx


def quaternion_error_matrix(quat: np.ndarray) -> np.ndarray:
    """(3, 4) E with E p = vec(conj(quat) * p) for a quaternion p [w, x, y, z].

    For a unit `quat` and a small change p of it, 2 E p is the rotation (rad, in quat's frame) from
    quat to quat + p: the first-order form of `mju_subQuat(quat + p, quat)`.
    """
    w, v = quat[0], quat[1:4]
    skew = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.hstack([-v[:, None], w * np.eye(3) - skew])


class Residuals:
    """Measurement residuals y - h(x) of a task's measured sensors, with quaternions as 3-D
    rotations.

    A jointpos, framepos, gyro, ... sensor's residual is y - h; a framequat or ballquat sensor's is
    the rotation r (rad) with h * exp(r) = y (`mju_subQuat`). Attributes:
        rows: (k,) each sensor's slice of the residual vector (size,).
        size: length of the full residual vector (measured size minus one per quaternion sensor).
    """

    def __init__(self, layout: MeasuredLayout) -> None:
        self.layout = layout
        self.is_quat = [t in QUATERNION_TYPES for t in layout.types]
        rows, start = [], 0
        for s, quat in zip(layout.slices, self.is_quat, strict=True):
            width = 3 if quat else s.stop - s.start
            rows.append(slice(start, start + width))
            start += width
        self.rows: list[slice] = rows
        self.size = start

    def row_indices(self, sensors: list[int]) -> np.ndarray:
        """int indices into the residual vector of the sensors numbered `sensors` (indices into
        layout.names)."""
        return np.concatenate([np.arange(self.rows[i].start, self.rows[i].stop) for i in sensors])

    def values(self, sensors: list[int], measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """(m,) the residual y - h(x) of the sensors numbered `sensors` (indices into layout.names),
        from the (layout.size,) `measured` and `predicted` values (only the listed sensors' entries
        are read)."""
        residual = []
        for i in sensors:
            s = self.layout.slices[i]
            if self.is_quat[i]:
                r = np.zeros(3)
                mujoco.mju_subQuat(r, measured[s], predicted[s] / np.linalg.norm(predicted[s]))
                residual.append(r)
            else:
                residual.append(measured[s] - predicted[s])
        return np.concatenate(residual)

    def evaluate(
        self, sensors: list[int], measured: np.ndarray, predicted: np.ndarray, jacobian: np.ndarray
    ):
        """Residual and its Jacobian for the sensors numbered `sensors`.

        Args:
            sensors: indices into layout.names of the sensors to use.
            measured: (layout.size,) measured values (only the listed sensors' entries are read).
            predicted: (layout.size,) h(x), the model's values at the estimate.
            jacobian: (layout.size, 2 nv + na) dh/dx of the measured values.
        Returns:
            (m,) residual y - h(x) and (m, 2 nv + na) G, with residual(x + dx) ~ residual(x) - G dx.
        """
        rows = []
        for i in sensors:
            s = self.layout.slices[i]
            if self.is_quat[i]:
                h = predicted[s] / np.linalg.norm(predicted[s])
                rows.append(2.0 * quaternion_error_matrix(h) @ jacobian[s])
            else:
                rows.append(jacobian[s])
        return self.values(sensors, measured, predicted), np.vstack(rows)
