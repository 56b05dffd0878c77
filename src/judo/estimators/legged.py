"""A contact-aided estimator of a legged robot's floating base, from what its low-level state
carries: the IMU (orientation, gyro, accelerometer), the joint encoders (positions, and velocities
where measured) and the feet's contact forces, on flat ground. No base position or velocity is
measured.

- Attitude: the IMU's orientation, smoothed by integrating the gyro (a complementary filter of time
  constant `attitude_time_constant`); the angular velocity is the gyro's.
- Joints: the encoders as read; their velocities as measured, else differenced from the encoders and
  smoothed.
- Base position, velocity and the feet: a linear Kalman filter over s = [p (3), v (3), f_1 .. f_k (3
  each)] in the world frame (p the base origin, v its velocity, f_i foot site i). It predicts p and
  v with the accelerometer's acceleration turned into the world frame by the attitude (gravity added
  back), and holds the feet where they are: a standing foot barely moves (`slip_std`), a swinging
  one freely (`swing_std`). Each reading corrects it with leg kinematics on the planning model at
  the measured joints and attitude: f_i - p = R fk_i(q) for every foot (`kinematics_std`), a
  standing foot's height is its site's height above a flat floor (`ground_std`), and where joint
  velocities are measured, a standing foot is still: v = -(the foot's velocity relative to the base,
  from the gyro and the joint velocities) (`foot_velocity_std`).
- Contact: a foot stands while its touch sensor reads over `contact_force`; with no touch sensors,
  while it is within `stance_band` of the lowest foot. With no foot pressed (lying, or in the air),
  the lowest foot is held on the floor loosely (`lowest_foot_std`), so the height never drifts far.

The height is observed through the standing feet, and the velocity through their kinematics; the
position in the plane is only integrated, so it drifts (as it does on a robot). Each reading is
fused at its stamp; the estimate is then carried to the requested time at constant velocities. Cost:
one `mj_kinematics` and `mj_comPos` and a Kalman update of 6 + 3k states per reading, no `mj_step`.
"""

from dataclasses import dataclass

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
from judo.core.reading import TIME_TOLERANCE, SystemState
from judo.core.task import Task
from judo.estimators.legged_layout import legged_layout

INITIAL_STD = (0.02, 0.2, 0.02)
"""Std of the first estimate's base position (m), velocity (m/s) and feet (m) about the first
reading's kinematics."""
SLIP_GATE = 16.27
"""A standing foot whose velocity is further than this squared normalised distance from the filter's
(chi-square of 3 degrees of freedom, 99.9%) slips: neither its height nor its velocity is fused, and
it moves freely."""


@slider("contact_force", 0.5, 100.0)
@slider("attitude_time_constant", 0.0, 0.5, 0.005)
@slider("accelerometer_std", 0.01, 10.0, log=True)
@slider("kinematics_std", 1e-4, 0.1, log=True)
@slider("foot_velocity_std", 1e-3, 2.0, log=True)
@slider("ground_std", 1e-4, 0.1, log=True)
@slider("slip_std", 1e-3, 1.0, log=True)
@dataclass
class LeggedConfig(EstimatorConfig):
    """The legged estimator's feet, contact rule and noise model."""

    foot_sites: tuple[str, ...] = ()
    """The sites at the feet (for a point foot, its centre); () takes the sites of the task's
    measured touch sensors, else the model's sites named "*foot"."""
    foot_sink: float | None = None
    """How deep (m) a standing foot sinks into the floor (a soft contact, a rubber foot); None: as
    deep as the planning model's feet sink once it has stood a second in its "home" keyframe (0
    without one)."""
    contact_force: float = 10.0
    """A foot stands while its touch sensor reads above this (N)."""
    stance_band: float = 0.02
    """Without touch sensors, a foot stands while it is within this (m) of the lowest foot."""
    attitude_time_constant: float = 0.1
    """Seconds over which the gyro-integrated attitude is pulled to the IMU's orientation; 0 takes
    it as read. A Go2 held standing with the IMU's orientation 0.5 deg noisy per axis: 0.37 deg off
    at 0.02 s, 0.18 at 0.1, 0.15 at 0.2; longer trusts the gyro's integral (and a real gyro's bias)
    longer."""
    joint_velocity_time_constant: float = 0.01
    """Without measured joint velocities, the time constant (s) smoothing the encoders'
    differences."""
    accelerometer_std: float = 0.5
    """How far (m/s per sqrt(s)) the base's velocity strays from the accelerometer's integral: its
    noise and bias, and the vibration between readings that one sample a reading misses."""
    kinematics_std: float = 0.005
    """Std (m) of a foot's position relative to the base by the leg's kinematics."""
    foot_velocity_std: float = 0.1
    """Std (m/s) of the base velocity that a standing foot's kinematics give."""
    ground_std: float = 0.005
    """Std (m) of a standing foot's height above the floor."""
    lowest_foot_std: float = 0.05
    """Std (m) of the lowest foot's height above the floor, when no foot stands."""
    slip_std: float = 0.02
    """How far (m per sqrt(s)) a standing foot may slide."""
    reanchor_distance: float = 0.05
    """A foot whose state is further than this (m) from where the kinematics put it is put back
    there."""
    swing_std: float = 3.0
    """How far (m per sqrt(s)) a swinging foot may move: effectively free."""

    def validate(self) -> None:
        super().validate()
        for name, value in vars(self).items():
            if name == "attitude_time_constant" or name == "joint_velocity_time_constant":
                require(value >= 0, f"LeggedConfig.{name} must be at least 0 s, got {value}")
            elif name == "foot_sink":
                require(
                    value is None or value >= 0,
                    f"LeggedConfig.foot_sink must be None or at least 0 m, got {value}",
                )
            elif name != "foot_sites":
                require(value > 0, f"LeggedConfig.{name} must be positive, got {value}")


class LeggedEstimator(Estimator[LeggedConfig]):
    """The floating base from the IMU, the encoders and the foot contacts (see the module
    docstring).

    Attributes:
        layout: where the base, joints, IMU and feet lie (`judo.estimators.legged_layout`).
        stance: (k,) which feet stood at the latest reading (pressed, or lowest, and not slipping).
        reanchors: feet put back where the kinematics put them (`reanchor_distance`), since the
            start.
        acceleration: (3,) the base's world acceleration at the latest reading (m/s^2), which
            carries it to the next.
        mean: (6 + 3k,) the Kalman filter's [p, v, feet] at the latest reading; cov: its (6 + 3k, 6
            + 3k) covariance.
    """

    config_cls = LeggedConfig

    def __init__(self, task: Task, config: LeggedConfig | None = None) -> None:
        super().__init__(task, config)
        self.model = task.model
        # the estimator's own kinematics; the plant's is never read
        self.data = mujoco.MjData(self.model)
        self.layout = legged_layout(task, self.config.foot_sites, self.config.foot_sink)
        k = len(self.layout.feet)
        self.stance = np.zeros(k, dtype=bool)
        self.mean, self.cov = np.zeros(6 + 3 * k), np.eye(6 + 3 * k)
        self.time = -np.inf
        self.quat = np.array([1.0, 0.0, 0.0, 0.0])
        self.omega = np.zeros(3)
        self.joints = self.model.qpos0[self.layout.joint_qpos].copy()
        self.joint_speeds = np.zeros(len(self.layout.joint_qpos))
        self.acceleration = np.zeros(3)
        self._jacobian = np.zeros((3, self.model.nv))
        self._started = False
        self.reanchors = 0

    # The contract.
    def reset(self, reading: SystemState) -> None:
        """Start from `reading`: the attitude and joints as read, the base at the model's keyframe 0
        (or qpos0) in the plane, as high as puts the lowest foot on the floor, at rest; a full
        `reading.state` gives the base's position and velocity instead."""
        sensors = check_sensors(self.task, reading, "legged")
        lay, model = self.layout, self.model
        self.quat = self._base_quat(sensors)
        self.omega = self._gyro(sensors)
        self.joints = sensors[lay.joint_pos].copy()
        self.joint_speeds = (
            np.zeros(len(self.joints)) if lay.joint_vel is None else sensors[lay.joint_vel].copy()
        )
        relative, _ = self._kinematics()
        start = model.key_qpos[0] if model.nkey else model.qpos0
        position = start[lay.base_qpos : lay.base_qpos + 3].copy()
        position[2] = float(np.max(lay.ground_offset - relative[:, 2]))
        velocity = np.zeros(3)
        if reading.state is not None:
            position = reading.state[lay.base_qpos : lay.base_qpos + 3].copy()
            velocity = reading.state[model.nq + lay.base_qvel : model.nq + lay.base_qvel + 3].copy()
        self.mean = np.concatenate([position, velocity, (position + relative).ravel()])
        k = len(lay.feet)
        stds = np.repeat([INITIAL_STD[0], INITIAL_STD[1], *([INITIAL_STD[2]] * k)], 3)
        self.cov = np.diag(stds**2)
        self.stance = self._contacts(sensors, relative)
        self.acceleration = self._acceleration(sensors)
        self.time = float(reading.time)
        self._started = True

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """Fuse `reading` if it is newer than the last one fused, and return the estimate carried to
        `time` at constant velocities; `controls` is not used (the IMU measures what they did)."""
        if not self._started:
            self.reset(reading)
        sensors = check_sensors(self.task, reading, "legged")
        if reading.time > self.time + TIME_TOLERANCE:
            self._fuse(sensors, float(reading.time) - self.time)
            self.time = float(reading.time)
        return estimate_of(
            reading, self._state_ahead(max(0.0, time - self.time)), max(time, self.time)
        )

    # The filter.
    def _fuse(self, sensors: np.ndarray, dt: float) -> None:
        """Predict the attitude, joints and Kalman filter over `dt` s and correct them with
        `sensors`."""
        lay, cfg = self.layout, self.config
        measured_quat = self._base_quat(sensors)
        self.omega = self._gyro(sensors)
        if cfg.attitude_time_constant > 0:
            mujoco.mju_quatIntegrate(self.quat, self.omega, dt)
            error = np.zeros(3)
            mujoco.mju_subQuat(error, measured_quat, self.quat)
            mujoco.mju_quatIntegrate(self.quat, error, dt / (cfg.attitude_time_constant + dt))
            mujoco.mju_normalize4(self.quat)
        else:
            self.quat = measured_quat
        joints = sensors[lay.joint_pos]
        if lay.joint_vel is not None:
            self.joint_speeds = sensors[lay.joint_vel].copy()
        else:
            share = dt / (cfg.joint_velocity_time_constant + dt)
            self.joint_speeds += share * ((joints - self.joints) / dt - self.joint_speeds)
        self.joints = joints.copy()
        relative, foot_velocity = self._kinematics()
        self.stance = self._contacts(sensors, relative)
        # the acceleration since the reading before: that reading's
        self._predict(self.acceleration, dt)
        self.acceleration = self._acceleration(sensors)
        self._correct(relative, foot_velocity)

    def _predict(self, acceleration: np.ndarray, dt: float) -> None:
        """The Kalman filter's prior `dt` s on under the (3,) world `acceleration` of the base."""
        cfg, n = self.config, len(self.mean)
        self.mean[:3] += self.mean[3:6] * dt + 0.5 * acceleration * dt**2
        self.mean[3:6] += acceleration * dt
        F = np.eye(n)
        F[:3, 3:6] = dt * np.eye(3)
        noise = np.zeros(n)
        noise[:3] = (0.5 * cfg.accelerometer_std * dt**1.5) ** 2
        noise[3:6] = cfg.accelerometer_std**2 * dt
        foot_std = np.where(self.stance, cfg.slip_std, cfg.swing_std)
        noise[6:] = np.repeat(foot_std**2 * dt, 3)
        self.cov = F @ self.cov @ F.T + np.diag(noise)

    def _correct(self, relative: np.ndarray, foot_velocity: np.ndarray) -> None:
        """Fuse the (k, 3) feet positions `relative` to the base (world frame) and, for standing
        feet, their heights and (where joint velocities are measured) their (k, 3) velocities
        `foot_velocity` to the base."""
        cfg, lay, n = self.config, self.layout, len(self.mean)
        self._reanchor(relative)
        if lay.joint_vel is not None:
            self.stance &= ~self._slipping(foot_velocity)
        rows, values, stds = [], [], []
        for i in range(len(lay.feet)):
            H = np.zeros((3, n))
            H[:, :3], H[:, 6 + 3 * i : 9 + 3 * i] = -np.eye(3), np.eye(3)
            rows.append(H)
            values.append(relative[i])
            stds.append(np.full(3, cfg.kinematics_std))
        standing = np.flatnonzero(self.stance)
        ground_std = cfg.ground_std
        if not len(standing):  # lying or airborne: hold the lowest foot loosely on the floor
            standing = np.array([int(np.argmin(relative[:, 2] - lay.ground_offset))])
            ground_std = cfg.lowest_foot_std
        for i in standing:
            H = np.zeros((1, n))
            H[0, 8 + 3 * i] = 1.0
            rows.append(H)
            values.append(lay.ground_offset[i : i + 1])
            stds.append([ground_std])
            if lay.joint_vel is not None and self.stance[i]:
                H = np.zeros((3, n))
                H[:, 3:6] = np.eye(3)
                rows.append(H)
                values.append(-foot_velocity[i])
                stds.append(np.full(3, cfg.foot_velocity_std))
        H, y = np.vstack(rows), np.concatenate(values)
        R = np.diag(np.concatenate(stds) ** 2)
        P = self.cov
        S = H @ P @ H.T + R
        K = np.linalg.solve(S, H @ P).T
        self.mean = self.mean + K @ (y - H @ self.mean)
        IKH = np.eye(n) - K @ H
        cov = IKH @ P @ IKH.T + K @ R @ K.T
        self.cov = 0.5 * (cov + cov.T)

    def _reanchor(self, relative: np.ndarray) -> None:
        """Put each foot whose state is over `reanchor_distance` from where the (k, 3) kinematics
        `relative` to the base put it back there, with its first std: the foot slid, or the robot
        was moved, by more than a foot held where it stood can follow."""
        cfg = self.config
        for i in range(len(relative)):
            feet = slice(6 + 3 * i, 9 + 3 * i)
            if (
                np.linalg.norm(self.mean[:3] + relative[i] - self.mean[feet])
                > cfg.reanchor_distance
            ):
                self.mean[feet] = self.mean[:3] + relative[i]
                self.cov[feet, :], self.cov[:, feet] = 0.0, 0.0
                self.cov[feet, feet] = INITIAL_STD[2] ** 2 * np.eye(3)
                self.reanchors += 1

    def _slipping(self, foot_velocity: np.ndarray) -> np.ndarray:
        """(k,) which standing feet move: the base velocity their (k, 3) `foot_velocity` gives lies
        more than SLIP_GATE normalised stds (chi-square, 3 degrees of freedom) from the filter's.
        The standing foot that agrees best never slips: were all of them to, nothing would pull a
        filter whose velocity is off back again."""
        R = self.config.foot_velocity_std**2 * np.eye(3)
        S = self.cov[3:6, 3:6] + R
        innovation = -foot_velocity - self.mean[3:6]
        distance = np.einsum("ki,ij,kj->k", innovation, np.linalg.inv(S), innovation)
        slipping = distance > SLIP_GATE
        if self.stance.any() and (slipping | ~self.stance).all():
            slipping[int(np.argmin(np.where(self.stance, distance, np.inf)))] = False
        return slipping

    # Measurements through the model.
    def _base_quat(self, sensors: np.ndarray) -> np.ndarray:
        """(4,) the base's orientation from the IMU site's measured one (the site's own rotation
        taken off)."""
        site = sensors[self.layout.imu["framequat"]]
        site = site / np.linalg.norm(site)
        inverse, base = np.zeros(4), np.zeros(4)
        mujoco.mju_negQuat(inverse, self.layout.imu_quat)
        mujoco.mju_mulQuat(base, site, inverse)
        return base

    def _gyro(self, sensors: np.ndarray) -> np.ndarray:
        """(3,) the base's angular velocity in its own frame (a free joint's qvel[3:6]) from the
        gyro's."""
        omega = np.zeros(3)
        mujoco.mju_rotVecQuat(omega, sensors[self.layout.imu["gyro"]], self.layout.imu_quat)
        return omega

    def _acceleration(self, sensors: np.ndarray) -> np.ndarray:
        """(3,) the base's world acceleration: the accelerometer's specific force in the world, plus
        gravity."""
        site = np.zeros(4)
        mujoco.mju_mulQuat(site, self.quat, self.layout.imu_quat)
        world = np.zeros(3)
        mujoco.mju_rotVecQuat(world, sensors[self.layout.imu["accelerometer"]], site)
        return world + self.model.opt.gravity

    def _kinematics(self) -> tuple[np.ndarray, np.ndarray]:
        """(k, 3) each foot site's position and (k, 3) the velocity of the foot's point touching the
        floor (`ground_offset` below the site), both relative to the base origin in the world frame,
        at the current attitude, angular velocity and joints. That point, not the site, is still
        while a round foot rolls: the centre of a Go2's 22 mm foot rolling with its calf's 10 rad/s
        moves at 0.2 m/s."""
        lay, model, data = self.layout, self.model, self.data
        data.qpos[:] = model.qpos0
        data.qpos[lay.base_qpos : lay.base_qpos + 3] = 0.0
        data.qpos[lay.base_qpos + 3 : lay.base_qpos + 7] = self.quat
        data.qpos[lay.joint_qpos] = self.joints
        data.qvel[:] = 0.0
        data.qvel[lay.base_qvel + 3 : lay.base_qvel + 6] = self.omega
        data.qvel[lay.joint_qvel] = self.joint_speeds
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        relative = data.site_xpos[lay.feet].copy()
        velocity = np.zeros_like(relative)
        for i, body in enumerate(lay.foot_bodies):
            point = relative[i] - np.array([0.0, 0.0, lay.ground_offset[i]])
            mujoco.mj_jac(model, data, self._jacobian, None, point, int(body))
            velocity[i] = self._jacobian @ data.qvel
        return relative, velocity

    def _contacts(self, sensors: np.ndarray, relative: np.ndarray) -> np.ndarray:
        """(k,) which feet stand: their touch sensors above `contact_force`, else those near the
        lowest."""
        if self.layout.touch is not None:
            return sensors[self.layout.touch] > self.config.contact_force
        height = relative[:, 2] - self.layout.ground_offset
        return height <= height.min() + self.config.stance_band

    def _state_ahead(self, ahead: float) -> np.ndarray:
        """(nq + nv,) the estimate `ahead` s after the latest reading, at constant velocities."""
        lay, model = self.layout, self.model
        qpos, qvel = model.qpos0.copy(), np.zeros(model.nv)
        qpos[lay.base_qpos : lay.base_qpos + 3] = self.mean[:3] + ahead * self.mean[3:6]
        quat = self.quat.copy()
        mujoco.mju_quatIntegrate(quat, self.omega, ahead)
        qpos[lay.base_qpos + 3 : lay.base_qpos + 7] = quat
        qpos[lay.joint_qpos] = self.joints + ahead * self.joint_speeds
        qvel[lay.base_qvel : lay.base_qvel + 3] = self.mean[3:6]
        qvel[lay.base_qvel + 3 : lay.base_qvel + 6] = self.omega
        qvel[lay.joint_qvel] = self.joint_speeds
        return np.concatenate([qpos, qvel])
