"""Extended Kalman filter on the task's planning model: predict with the applied controls, correct
with the measured sensors, fuse late readings at the time they were taken.

The filter keeps one node per planning-model timestep over the last `history` seconds: the prior
state and covariance there, the measurements taken then, and the Jacobians from
`mujoco.mjd_transitionFD` (A, the step's state Jacobian, and C, the sensors' state Jacobian; no
derivative is written by hand). A reading stamped in the past is added to its node, and the nodes
from there on are recomputed: the mean through the model again (`mj_step` with the controls applied
since), the covariance through the Jacobians stored when each node was first reached. So a 40 ms
camera delay costs four cheap replays, not four finite-difference Jacobians, and does not turn into
40 ms of stale state.
"""

from dataclasses import dataclass, field
from typing import ClassVar

import mujoco
import numpy as np

from judo.core.configuration.config import require
from judo.core.configuration.fields import slider
from judo.core.estimator import (
    ControlHistory,
    Estimator,
    EstimatorConfig,
    check_sensors,
    estimate_of,
)
from judo.core.reading import TIME_TOLERANCE, SystemState, set_mocap_poses
from judo.core.task import Task
from judo.estimators.tangent import Residuals, TangentSpace

RESET_ITERATIONS = 5
"""Gauss-Newton iterations of the first correction (an iterated EKF), which starts far from the
truth."""
COVARIANCE_CAP = 10.0
"""No variance grows past this many times the initial std, squared (see `_capped`)."""


@slider("process_noise_position", 1e-5, 1.0, log=True)
@slider("process_noise_velocity", 1e-3, 100.0, log=True)
@slider("noise_jointpos", 1e-5, 0.1, log=True)
@slider("noise_framepos", 1e-5, 0.1, log=True)
@slider("noise_framequat", 1e-4, 0.5, log=True)
@slider("noise_gyro", 1e-4, 1.0, log=True)
@slider("noise_accelerometer", 1e-3, 10.0, log=True)
@slider("noise_other", 1e-5, 1.0, log=True)
@slider("history", 0.0, 1.0, 0.01)
@slider("fd_epsilon", 1e-7, 1e-2, log=True)
@dataclass
class KalmanConfig(EstimatorConfig):
    """The noise model and bookkeeping that the Kalman filters here share (EKF, UKF)."""

    process_noise_position: float = 0.01
    """Std of the model's position error, (m or rad) per sqrt(s): how far the truth drifts from a
    prediction."""
    process_noise_velocity: float = 0.2
    """Std of the model's velocity error, (m/s or rad/s) per sqrt(s); raise it for contacts the
    model gets wrong."""
    noise_jointpos: float = 0.005
    """Std of a joint encoder (rad or m)."""
    noise_framepos: float = 0.002
    """Std of a measured position, e.g. a camera's (m)."""
    noise_framequat: float = 0.02
    """Std of a measured orientation, per axis (rad)."""
    noise_gyro: float = 0.01
    """Std of a gyro (rad/s)."""
    noise_accelerometer: float = 1.0
    """Std of an accelerometer (m/s^2). Far above a real IMU's: a contact the model gets slightly
    wrong moves the acceleration by metres per second squared, and trusting it more drives walker's
    estimate off the floor."""
    noise_other: float = 0.01
    """Std of any other sensor type, in its own unit."""
    initial_position_std: float = 0.3
    """Std of the first guess's positions (m or rad) before the first reading is fused."""
    initial_velocity_std: float = 1.0
    """Std of the first guess's velocities (m/s or rad/s)."""
    history: float = 0.2
    """Seconds of past steps kept to fuse late readings at the time they were taken; older ones are
    dropped."""
    fd_epsilon: float = 1e-3
    """Finite-difference step of the Jacobians (m, rad, m/s, ...): the EKF's at every step, the
    UKF's for its first reading only. Far above rounding's optimum: a contact solver stopped after a
    few iterations is noisy, and at 1e-6 that noise made leap_cube's Jacobian entries 1e5 and the
    filter lose the cube; 1e-3 did not."""

    def validate(self) -> None:
        super().validate()
        for name, value in vars(self).items():
            if name != "history":
                require(value > 0, f"{type(self).__name__}.{name} must be positive, got {value}")
        require(
            self.history >= 0,
            f"{type(self).__name__}.history must be at least 0 s, got {self.history}",
        )

    def sensor_std(self, sensor_type: str) -> float:
        """The std of a sensor of `sensor_type` ("jointpos", ...), `noise_other` for a type without
        a field."""
        return float(getattr(self, f"noise_{sensor_type}", self.noise_other))


@slider("relinearize_every", 1, 20, 1)
@dataclass
class EKFConfig(KalmanConfig):
    """Extended Kalman filter noise model and bookkeeping."""

    relinearize_every: int = 1
    """Compute the Jacobians every this many steps and reuse them in between (cheaper, less
    exact)."""


@dataclass
class _Node:
    """One step of the filter's timeline (index: steps since the reset's time)."""

    index: int
    prior: np.ndarray  # (nq + nv + na,)
    prior_cov: np.ndarray  # (n, n), n = 2 nv + na
    measured: dict[int, np.ndarray] = field(default_factory=dict)  # sensor number -> its values
    jacobians: tuple[np.ndarray, np.ndarray] | None = None  # A (n, n), C (measured size, n)
    posterior: tuple[np.ndarray, np.ndarray] | None = None


class ExtendedKalmanFilter(Estimator[EKFConfig]):
    """EKF over [qpos, qvel, act] with a (2 nv + na)-square tangent-space covariance.

    Attributes:
        dropped_readings: sensor values that arrived later than `history` and were not fused.
        linearizations: calls of `mjd_transitionFD` so far (one per step, or fewer with
            relinearize_every).
    """

    config_cls = EKFConfig
    name: ClassVar[str] = "ekf"
    """How the filter names itself in its errors: its registered name (a subclass names its own)."""

    def __init__(self, task: Task, config: EKFConfig | None = None) -> None:
        super().__init__(task, config)
        self.model = task.model
        # the filter's own; the plant's task.data is never read
        self.data = mujoco.MjData(self.model)
        self.space = TangentSpace(self.model)
        self.residuals = Residuals(task.measured)
        self.dt = float(self.model.opt.timestep)
        n = self.space.size
        self._A, self._C = np.zeros((n, n)), np.zeros((self.model.nsensordata, n))
        self.nodes: list[_Node] = []
        self.start_time = 0.0
        self._fused = np.full(len(task.measured.names), -np.inf)  # newest stamp fused, per sensor
        self.dropped_readings = 0
        self.linearizations = 0
        self._controls = ControlHistory(self.model.nu)

    # The contract.
    def reset(self, reading: SystemState) -> None:
        """Start from `reading`: its state if it has one, else the model's keyframe 0 (or qpos0),
        then fuse its sensors with RESET_ITERATIONS Gauss-Newton steps."""
        sensors = check_sensors(self.task, reading, self.name)
        set_mocap_poses(self.model, self.data, reading.metadata)
        if reading.state is not None:
            x0 = np.concatenate([reading.state, np.zeros(self.model.na)])
        else:
            if self.model.nkey:
                mujoco.mj_resetDataKeyframe(self.model, self.data, 0)
            else:
                mujoco.mj_resetData(self.model, self.data)
            x0 = np.concatenate([self.data.qpos, self.data.qvel, self.data.act])
        nv, cfg = self.model.nv, self.config
        stds = np.r_[
            np.full(nv, cfg.initial_position_std),
            np.full(self.space.size - nv, cfg.initial_velocity_std),
        ]
        self.start_time = float(reading.time)
        self.nodes = [_Node(0, x0, np.diag(stds**2))]
        self._fused[:] = -np.inf
        self.dropped_readings = 0
        self._controls = ControlHistory(self.model.nu)
        node = self.nodes[0]
        node.measured = {i: sensors[s] for i, s in enumerate(self.task.measured.slices)}
        self._fused[:] = self._stamps(reading)
        self._correct(node, iterations=RESET_ITERATIONS)

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """See `Estimator.update`. The estimate is at the filter step nearest `time` (steps of the
        planning model's timestep from the reset's time), never earlier than the newest step already
        reached."""
        if not self.nodes:
            self.reset(reading)
        sensors = check_sensors(self.task, reading, self.name)
        set_mocap_poses(self.model, self.data, reading.metadata)
        self._controls = controls
        target = max(self._index(time), self.nodes[-1].index)
        first = self.nodes[0].index
        pending: dict[int, dict[int, np.ndarray]] = {}
        for i, stamp in enumerate(self._stamps(reading)):
            if stamp <= self._fused[i] + TIME_TOLERANCE:
                continue  # held since it was fused
            self._fused[i] = stamp
            index = min(self._index(stamp), target)
            if index < first:
                self.dropped_readings += 1
                continue
            pending.setdefault(index, {})[i] = sensors[self.task.measured.slices[i]]
        last = self.nodes[-1].index
        # fused where taken, then replayed forward
        late = [index for index in pending if index <= last]
        for index in late:
            self._node(index).measured.update(pending[index])
        start = min(late, default=last)
        for node in self.nodes[start - first :] if late else ():
            node.posterior = None
        for index in range(start, target):
            self._predict(index, pending.get(index + 1, {}))
        head = self._node(target)
        x, _ = self._posterior(head)
        self._forget_before(target - round(self.config.history / self.dt))
        return estimate_of(
            reading, x[: self.model.nq + self.model.nv], self.start_time + target * self.dt
        )

    def covariance(self) -> np.ndarray | None:
        """(2 nv + na, 2 nv + na) posterior covariance at the newest step."""
        return None if not self.nodes else self._posterior(self.nodes[-1])[1].copy()

    # Steps of the filter.
    def _predict(self, index: int, arriving: dict[int, np.ndarray]) -> None:
        """Node index + 1's prior from node index's posterior: the mean through mj_step, the
        covariance through A."""
        node = self._node(index)
        x, cov = self._posterior(node)
        time = self.start_time + index * self.dt
        self._set_state(x, time, self._controls.at(time + 0.5 * self.dt))
        mujoco.mj_step(self.model, self.data)
        prior = np.concatenate([self.data.qpos, self.data.qvel, self.data.act])
        assert node.jacobians is not None  # set by _posterior
        A = node.jacobians[0]
        self._set_prior(
            index + 1, prior, self._capped(A @ cov @ A.T + self._process_noise()), arriving
        )

    def _set_prior(
        self, index: int, prior: np.ndarray, prior_cov: np.ndarray, arriving: dict[int, np.ndarray]
    ) -> None:
        """Give node `index` (appended if new) this prior and the readings `arriving` there; its
        posterior is stale."""
        if index <= self.nodes[-1].index:
            following = self._node(index)
            following.prior, following.prior_cov, following.posterior = prior, prior_cov, None
            following.measured.update(arriving)
        else:
            self.nodes.append(_Node(index, prior, prior_cov, dict(arriving)))

    def _process_noise(self) -> np.ndarray:
        """(n, n) the process noise added over one step."""
        nv, na, cfg = self.model.nv, self.model.na, self.config
        noise = np.r_[
            np.full(nv, cfg.process_noise_position), np.full(nv + na, cfg.process_noise_velocity)
        ]
        return np.diag(noise**2 * self.dt)

    def _posterior(self, node: _Node) -> tuple[np.ndarray, np.ndarray]:
        """(state, covariance) after fusing the node's measurements (computed once, until the node
        changes)."""
        if node.jacobians is None:
            node.jacobians = self._jacobians_for(node)
        if node.posterior is None:
            self._correct(node, iterations=1)
        assert node.posterior is not None  # set by _correct
        return node.posterior

    def _correct(self, node: _Node, iterations: int) -> None:
        """Fuse the node's measurements into its prior (Joseph form); `iterations` > 1 relinearizes
        (IEKF)."""
        if not node.measured:
            node.posterior = (node.prior.copy(), node.prior_cov.copy())
            if node.jacobians is None:
                node.jacobians = self._jacobians_for(node)
            return
        numbers, measured, R = self._measurement(node)
        P, x0, x = node.prior_cov, node.prior, node.prior
        K = G = np.zeros((0, 0))
        time = self.start_time + node.index * self.dt
        for _ in range(iterations):
            if iterations > 1 or node.jacobians is None:
                node.jacobians = (
                    self._linearize(x, time) if iterations > 1 else self._jacobians_for(node)
                )
            predicted = self._sensors_at(x, time)
            residual, G = self.residuals.evaluate(numbers, measured, predicted, node.jacobians[1])
            residual = residual + G @ self.space.minus(x, x0)  # zero on the first pass
            S = G @ P @ G.T + R
            K = np.linalg.solve(S, G @ P).T  # P G^T S^-1, P and S symmetric
            x = self.space.plus(x0, K @ residual)
        IKG = np.eye(len(P)) - K @ G
        cov = IKG @ P @ IKG.T + K @ R @ K.T
        node.posterior = (x, 0.5 * (cov + cov.T))

    def _measurement(self, node: _Node) -> tuple[list[int], np.ndarray, np.ndarray]:
        """The node's sensor numbers (sorted), their values in a (measured size,) vector (zeros
        elsewhere), and the (m, m) measurement noise R of their residual rows."""
        numbers = sorted(node.measured)
        measured = np.zeros(self.task.measured.size)
        for i in numbers:
            measured[self.task.measured.slices[i]] = node.measured[i]
        std = np.concatenate(
            [
                np.full(r.stop - r.start, self.config.sensor_std(self.task.measured.types[i]))
                for i, r in self._rows(numbers)
            ]
        )
        return numbers, measured, np.diag(std**2)

    def _capped(self, cov: np.ndarray) -> np.ndarray:
        """`cov` with each variance above COVARIANCE_CAP^2 times the initial one scaled down to that
        (D cov D, D diagonal: still SPD).

        A Jacobian taken across a contact switch can have huge entries, and the covariance it
        spreads would let one encoder reading throw the velocities off; the cap is far above what a
        working filter reaches.
        """
        nv, cfg = self.model.nv, self.config
        stds = np.r_[
            np.full(nv, cfg.initial_position_std),
            np.full(self.space.size - nv, cfg.initial_velocity_std),
        ]
        cap = (COVARIANCE_CAP * stds) ** 2
        scale = np.sqrt(np.minimum(1.0, cap / np.maximum(np.diag(cov), 1e-300)))
        return cov * scale[:, None] * scale[None, :]

    # Model evaluations.
    def _jacobians_for(self, node: _Node) -> tuple[np.ndarray, np.ndarray]:
        """The node's (A, C): fresh every `relinearize_every` steps, else the previous node's."""
        if node.index % self.config.relinearize_every and node.index > self.nodes[0].index:
            previous = self._node(node.index - 1)
            if previous.jacobians is not None:
                return previous.jacobians
        return self._linearize(node.prior, self.start_time + node.index * self.dt)

    def _linearize(self, x: np.ndarray, time: float) -> tuple[np.ndarray, np.ndarray]:
        """(A (n, n), C (measured size, n)) of one step from `x` under the control in force after
        `time`."""
        self._set_state(x, time, self._controls.at(time + 0.5 * self.dt))
        mujoco.mjd_transitionFD(
            self.model, self.data, self.config.fd_epsilon, 0, self._A, None, self._C, None
        )
        self.linearizations += 1
        return self._A.copy(), self._C[self.task.measured.columns].copy()

    def _sensors_at(self, x: np.ndarray, time: float) -> np.ndarray:
        """(measured size,) h(x): the measured sensors at `x` under the control in force before
        `time`."""
        self._set_state(x, time, self._controls.at(time - 0.5 * self.dt))
        mujoco.mj_forward(self.model, self.data)
        return self.task.measured.read(self.data.sensordata)

    def _set_state(self, x: np.ndarray, time: float, ctrl: np.ndarray) -> None:
        nq, nv = self.model.nq, self.model.nv
        self.data.qpos[:], self.data.qvel[:], self.data.act[:] = (
            x[:nq],
            x[nq : nq + nv],
            x[nq + nv :],
        )
        self.data.ctrl[:], self.data.time = ctrl, time

    # Bookkeeping.
    def _index(self, time: float) -> int:
        return round((time - self.start_time) / self.dt)

    def _node(self, index: int) -> _Node:
        return self.nodes[index - self.nodes[0].index]

    def _rows(self, numbers: list[int]) -> list[tuple[int, slice]]:
        return [(i, self.residuals.rows[i]) for i in numbers]

    def _stamps(self, reading: SystemState) -> np.ndarray:
        """(k,) when each measured sensor's value was taken: metadata "sensor_times", else
        reading.time."""
        stamps = reading.metadata.get("sensor_times")
        if stamps is None:
            return np.full(len(self.task.measured.names), float(reading.time))
        return np.asarray(stamps, dtype=float)

    def _forget_before(self, index: int) -> None:
        drop = min(max(0, index - self.nodes[0].index), len(self.nodes) - 1)
        del self.nodes[:drop]
