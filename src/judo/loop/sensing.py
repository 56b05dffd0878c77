"""Rehearsed sensing: the simulator seen through a robot's sensors, noisy, late and at their own
rates.

    system = SensedSystem(MujocoSystem(task), noise={"default": 0.005, "framequat": 0.017},
                          delay={"framepos": 0.04, "framequat": 0.04}, rate={"default": 100, "framepos": 30})

Each setting is one value for every measured sensor or a mapping {sensor type: value} with an
optional "default" (see `judo.core.sensors.per_sensor`).

How a command's simulated plant is observed (`Sensing`, `observed_plant`, `choose_estimator` and
their flags) is the commands' choice: `judo.evaluation.sensing`.
"""  # noqa: E501

from collections import deque
from collections.abc import Mapping

import mujoco
import numpy as np

from judo.core.configuration.config import require
from judo.core.reading import TIME_TOLERANCE, SystemState
from judo.core.sensors import QUATERNION_TYPES, per_sensor
from judo.loop.system import MujocoSystem, System

PerType = float | Mapping[str, float | None] | None
"""One value for every measured sensor, or {sensor type: value} with an optional "default" key."""


class SensedSystem(System):
    """A simulated plant that serves only its task's measured sensors (`SystemState.state` is None).

    Each measured sensor is sampled at its rate, gets Gaussian noise (a quaternion sensor a random
    rotation of that std per axis, in rad), and is delivered `delay` seconds later, stamped with the
    time it was taken; between samples the last delivered value is held. The reading's `time` is the
    newest stamp and `metadata["sensor_times"]` (k,) holds each sensor's stamp. The sample taken at
    reset is delivered at once, so a loop always has a reading to start from.

    Args:
        system: the simulated plant; its task's `sim_measured` says which sensors are served.
        noise: std per sensor (its unit: rad, m, rad/s, m/s^2); None or 0: noiseless.
        delay: seconds from taking a sample to delivering it; None or 0: at once.
        rate: samples per second; None: every plant step.
        rng: the generator the noise draws from (seed it for a reproducible episode).
    """

    def __init__(
        self,
        system: MujocoSystem,
        noise: PerType = None,
        delay: PerType = None,
        rate: PerType = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.system = system
        self.task = system.task
        self.timestep = system.timestep
        self.layout = self.task.sim_measured
        require(
            self.layout.size > 0,
            f"{type(self.task).__name__} declares no measured sensors; list the MJCF sensors "
            "a robot has in "
            f"{type(self.task).__name__}.measured_sensors",
        )
        self.noise = np.array([v or 0.0 for v in per_sensor(noise, self.layout, "sensor noise")])
        self.delay = np.array([v or 0.0 for v in per_sensor(delay, self.layout, "sensor delay")])
        rates = per_sensor(rate, self.layout, "sensor rate")
        for what, values in (("noise", self.noise), ("delay", self.delay)):
            require(
                bool((values >= 0).all()),
                f"sensor {what} must be at least 0, got {values.tolist()}",
            )
        require(
            all(r is None or r > 0 for r in rates), f"sensor rate must be above 0 Hz, got {rates}"
        )
        self.period = np.array([0.0 if r is None else 1.0 / r for r in rates])
        """(k,) seconds between samples of each sensor (0: every step)."""
        self.rng = rng if rng is not None else np.random.default_rng()
        k = len(self.layout.names)
        self._in_flight: list[deque[tuple[float, float, np.ndarray]]] = [deque() for _ in range(k)]
        self._stamps = np.zeros(k)
        self._values = np.zeros(self.layout.size)
        self._next_sample = np.full(k, self.time)
        self._sample(deliver_at_once=True)  # the task was reset when it was built

    @property
    def time(self) -> float:
        """The plant's current time (s): the time a plan made now starts from, later than a delayed
        reading's."""
        return float(self.task.data.time)

    def plant_sensors(self) -> np.ndarray:
        """(nsensordata,) every sensor of the simulated plant, noiseless and current, for logs and
        metrics (the controller sees only `read_state`)."""
        return self.task.data.sensordata.copy()

    def plant_state(self) -> np.ndarray | None:
        """(nq + nv,) the simulated plant's true state, for logs and metrics (the controller never
        sees it)."""
        return self.system.plant_state()

    def reset(self) -> None:
        self.system.reset()
        for queue in self._in_flight:
            queue.clear()
        self._next_sample[:] = self.time
        self._sample(deliver_at_once=True)

    def apply(self, action: np.ndarray) -> None:
        self.system.apply(action)

    def step(self) -> None:
        """One plant step, then the samples that fall due are taken and those whose delay has passed
        arrive."""
        try:
            self.system.step()
        finally:
            self._sample()

    def read_state(self) -> SystemState:
        """The measured sensors last delivered (state None); see the class docstring for the
        stamps."""
        metadata = self.system.read_state().metadata
        metadata["sensor_times"] = self._stamps.copy()
        return SystemState(None, float(self._stamps.max()), metadata, self._values.copy())

    def _sample(self, deliver_at_once: bool = False) -> None:
        now = self.time
        due = np.flatnonzero(now >= self._next_sample - TIME_TOLERANCE)
        if len(due):
            true = self.system.sensor_values()
            for i in due:
                arrival = now if deliver_at_once else now + self.delay[i]
                self._in_flight[i].append(
                    (arrival, now, self._noisy(int(i), true[self.layout.slices[i]]))
                )
                # on the rate's grid, unless it fell behind
                following = self._next_sample[i] + self.period[i]
                self._next_sample[i] = (
                    following if following > now + TIME_TOLERANCE else now + self.period[i]
                )
        for i, queue in enumerate(self._in_flight):
            while queue and queue[0][0] <= now + TIME_TOLERANCE:
                _, self._stamps[i], self._values[self.layout.slices[i]] = queue.popleft()

    def _noisy(self, i: int, values: np.ndarray) -> np.ndarray:
        std = self.noise[i]
        if not std:
            return values.copy()
        if self.layout.types[i] in QUATERNION_TYPES:
            quat = values / np.linalg.norm(values)
            mujoco.mju_quatIntegrate(quat, self.rng.normal(0.0, std, 3), 1.0)
            return quat
        return values + self.rng.normal(0.0, std, values.shape)
