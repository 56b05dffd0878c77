"""Unscented Kalman filter on the task's planning model: the EKF's timeline (late readings fused
where they were taken, then replayed forward), with the covariance carried through MuJoCo by sigma
points instead of finite-difference Jacobians.

Each step draws 2n sigma points x + s sqrt(n) L e_i and x - s sqrt(n) L e_i (n = 2 nv + na, L the
Cholesky factor of the tangent-space covariance, e_i the unit vectors, s the config's `spread`),
steps every one through `mj_step` under the applied control, and takes their mean and spread
(divided by s^2) as the next prior. The correction passes the points through the measured sensors
the same way. With spread 1 this is the cubature rule (the unscented transform with equal weights
and no centre point): exact for linear dynamics and sensors, and, unlike a Jacobian taken at one
state, it sees a contact that only some of the nearby states make.

Cost per plant step: 2n `mj_step`s to predict and 2n `mj_forward`s to correct (walker: n = 18;
leap_cube: n = 44), and 2n more `mj_step`s for each step replayed after a late reading. The first
reading is fused by the EKF's iterated update, because the first guess (the keyframe, with
`initial_position_std`) is too far off for sigma points that far out to stay out of the floor.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.task import Task
from judo.estimators.ekf import RESET_ITERATIONS, ExtendedKalmanFilter, KalmanConfig, _Node


@slider("spread", 0.05, 1.0)
@dataclass
class UKFConfig(KalmanConfig):
    """Unscented Kalman filter noise model, bookkeeping and sigma-point spread."""

    spread: float = 1.0
    """How far out the sigma points lie, as a fraction of the cubature rule's sqrt(n) stds. 1 is the
    cubature rule; smaller probes closer to the estimate, like a finite difference (walker with
    docs/estimation.md's sensing, seeds 0-4: 1.42 m/s at 1, 1.41 at 0.3, 0.83 at 0.1)."""


class UnscentedKalmanFilter(ExtendedKalmanFilter):
    """UKF over [qpos, qvel, act] with a (2 nv + na)-square tangent-space covariance (see the module
    docstring)."""

    config_cls = UKFConfig
    config: UKFConfig  # the config Estimator.__init__ stores (see __init__)
    name = "ukf"

    def __init__(self, task: Task, config: UKFConfig | None = None) -> None:
        # not an EKFConfig: _jacobians_for, which reads relinearize_every, is overridden
        super().__init__(task, config)  # type: ignore[arg-type]

    def _jacobians_for(self, node: _Node) -> tuple[np.ndarray, np.ndarray]:
        """Fresh Jacobians: only the first reading's iterated update uses them (no reuse to
        configure)."""
        return self._linearize(node.prior, self.start_time + node.index * self.dt)

    def _posterior(self, node: _Node) -> tuple[np.ndarray, np.ndarray]:
        """(state, covariance) after fusing the node's measurements (computed once, until the node
        changes): the reset's node by the EKF's iterated update, every later one through sigma
        points."""
        if node.posterior is None:
            if node.index == 0:
                self._correct(node, iterations=RESET_ITERATIONS)
            else:
                self._sigma_correct(node)
        assert node.posterior is not None  # set by _correct / _sigma_correct
        return node.posterior

    def _sigma_points(self, x: np.ndarray, cov: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """The 2n states x + offset_i and the (2n, n) tangent offsets, +-spread sqrt(n) times L's
        columns."""
        n = len(cov)
        symmetric = 0.5 * (cov + cov.T)
        try:
            root = np.linalg.cholesky(symmetric)
        except np.linalg.LinAlgError:  # rounding made it semi-definite: clip the eigenvalues
            values, vectors = np.linalg.eigh(symmetric)
            root = vectors * np.sqrt(np.maximum(values, 1e-12))
        scale = self.config.spread * np.sqrt(n)
        offsets = scale * np.concatenate([root.T, -root.T])
        return [self.space.plus(x, offset) for offset in offsets], offsets

    def _predict(self, index: int, arriving: dict[int, np.ndarray]) -> None:
        """Node index + 1's prior: every sigma point of node index's posterior through mj_step."""
        x, cov = self._posterior(self._node(index))
        time = self.start_time + index * self.dt
        ctrl = self._controls.at(time + 0.5 * self.dt)
        # the deviations are taken around the mean's own step
        reference = self._stepped(x, time, ctrl)
        points, _ = self._sigma_points(x, cov)
        deviations = np.array(
            [self.space.minus(self._stepped(p, time, ctrl), reference) for p in points]
        )
        mean = deviations.mean(axis=0)
        centred = deviations - mean
        spread_sq = self.config.spread**2
        prior_cov = centred.T @ centred / (len(points) * spread_sq) + self._process_noise()
        self._set_prior(
            index + 1, self.space.plus(reference, mean), self._capped(prior_cov), arriving
        )

    def _stepped(self, x: np.ndarray, time: float, ctrl: np.ndarray) -> np.ndarray:
        """(nq + nv + na,) the state one mj_step after `x` under `ctrl`."""
        self._set_state(x, time, ctrl)
        mujoco.mj_step(self.model, self.data)
        return np.concatenate([self.data.qpos, self.data.qvel, self.data.act])

    def _sigma_correct(self, node: _Node) -> None:
        """Fuse the node's measurements into its prior with the sigma points' residuals."""
        x, cov = node.prior, node.prior_cov
        if not node.measured:
            node.posterior = (x.copy(), cov.copy())
            return
        numbers, measured, R = self._measurement(node)
        time = self.start_time + node.index * self.dt
        points, offsets = self._sigma_points(x, cov)
        residuals = np.array(
            [self.residuals.values(numbers, measured, self._sensors_at(p, time)) for p in points]
        )
        mean = residuals.mean(axis=0)  # y - E[h(x)]
        centred = residuals - mean  # -(h_i - E[h])
        spread_sq = self.config.spread**2
        innovation_cov = centred.T @ centred / (len(points) * spread_sq) + R
        cross_cov = -offsets.T @ centred / (len(points) * spread_sq)  # (n, m) cov(x, h(x))
        gain = np.linalg.solve(innovation_cov, cross_cov.T).T
        posterior_cov = cov - gain @ innovation_cov @ gain.T
        node.posterior = (self.space.plus(x, gain @ mean), 0.5 * (posterior_cov + posterior_cov.T))
