"""Going to hardware: drive your own `System` with the unchanged app, controller and GUI.

The app only talks to its plant through `judo.loop.system.System`: `read_state()`, `apply(action)`,
`step()` and `reset()`. Here a stand-in "robot" implements it: an in-process cart-pole that is not
quite the model the controller plans with (its pole is 10% heavier), whose motor takes a while to
respond, and which measures what a real one does: its two joint encoders (the task's
`Cartpole.measured_sensors`), noisy, at 100 Hz and 20 ms late, each reading stamped with the time it
was taken. It never reports velocities, so `read_state` returns `state=None`, and the app runs the
extended Kalman filter, cartpole's default (`estimator="ekf"`), to estimate the full state the
planner needs. Swap this class for one that talks to your robot's drivers and nothing else changes.

    python examples/06_hardware_system.py                          # GUI at http://localhost:8080
    python examples/06_hardware_system.py --headless --duration 5  # prints a summary

Any judo command that takes `--system module:Class` builds it as `Class(task)`, e.g. from this
folder a log of the robot for `python -m judo sysid` (docs/sysid.md):

    python -m judo excite --task cartpole --system 06_hardware_system:LaggyNoisyCartpole --duration 20 --out robot.h5
"""  # noqa: E501

import argparse
from collections import deque

import mujoco
import numpy as np

import judo
from judo import System, SystemState
from judo.estimators.ekf import EKFConfig
from judo.tasks.cartpole import MODEL_PATH


class LaggyNoisyCartpole(System):
    """A simulated cart-pole robot that measures only its encoders, noisy, late and at their own
    rate.

    Args:
        task: the task instance `--system` builds it with (unused: the robot is its own physics).
        sensor_latency: seconds from taking an encoder sample to its reaching `read_state`.
        actuation_latency: seconds before an applied action reaches the motor.
        noise_std: std of the Gaussian noise on each encoder (m for the cart, rad for the pole).
        sensor_rate: encoder samples per second.
        pole_mass_scale: how much heavier the real pole is than in the planning model.
        seed: seeds the noise and the start state.
    """

    def __init__(
        self,
        task: object = None,
        sensor_latency: float = 0.02,
        actuation_latency: float = 0.01,
        noise_std: float = 0.005,
        sensor_rate: float = 100.0,
        pole_mass_scale: float = 1.1,
        seed: int = 0,
    ) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(MODEL_PATH))
        pole = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "pole")
        # our own copy: the planner's model is untouched
        self.model.body_mass[pole] *= pole_mass_scale
        self.data = mujoco.MjData(self.model)
        self.timestep = float(self.model.opt.timestep)
        self.sensor_latency, self.actuation_latency, self.noise_std = (
            sensor_latency,
            actuation_latency,
            noise_std,
        )
        self.sensor_period = 1.0 / sensor_rate
        self.rng = np.random.default_rng(seed)
        # (time taken, noisy encoders (2,))
        self._measurements: deque[tuple[float, np.ndarray]] = deque()
        self._next_sample = 0.0
        self._commands: deque[tuple[float, np.ndarray]] = deque()  # (time due at the motor, action)
        del task
        self.reset()

    def reset(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = [0.0, np.pi] + self.rng.normal(0.0, 0.1, 2)  # pole hanging down
        mujoco.mj_forward(self.model, self.data)
        self._measurements.clear()
        self._commands.clear()
        self._next_sample = self.data.time
        self._measure()

    @property
    def time(self) -> float:
        """The robot's clock now (s): the estimator predicts a late reading forward to it."""
        return float(self.data.time)

    def read_state(self) -> SystemState:
        """The newest encoder sample that has arrived by now, stamped with the time it was *taken*.

        `state` is None (the robot does not know its velocities); `sensors` holds the (2,) encoder
        values in the order of `Cartpole.measured_sensors`: cart position (m), pole angle (rad)."""
        now = self.data.time
        while (
            len(self._measurements) > 1
            and self._measurements[1][0] <= now - self.sensor_latency + 1e-9
        ):
            self._measurements.popleft()
        taken, encoders = self._measurements[0]
        return SystemState(None, taken, {}, encoders.copy())

    def apply(self, action: np.ndarray) -> None:
        self._commands.append(
            (self.data.time + self.actuation_latency, np.array(action, dtype=float))
        )

    def step(self) -> None:
        while self._commands and self._commands[0][0] <= self.data.time + 1e-9:
            self.data.ctrl[:] = self._commands.popleft()[1]
        mujoco.mj_step(self.model, self.data)
        self._measure()

    def _measure(self) -> None:
        """Take an encoder sample when one is due (at `sensor_rate`), with noise."""
        if self.data.time < self._next_sample - 1e-9:
            return
        self._next_sample += self.sensor_period
        # slider (m) and hinge (rad): what the two jointpos sensors read
        encoders = self.data.qpos.copy()
        self._measurements.append(
            (self.data.time, encoders + self.rng.normal(0.0, self.noise_std, encoders.shape))
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--headless", action="store_true", help="run without the GUI")
    parser.add_argument("--duration", type=float, default=None, help="seconds of robot time to run")
    parser.add_argument("--port", type=int, default=8080, help="port of the GUI")
    args = parser.parse_args()
    robot = LaggyNoisyCartpole()
    app = judo.App(
        task="cartpole",
        optimizer="mppi",
        # its readings have state None: the app picks cartpole's default estimator, "ekf"
        system=robot,
        estimator_config=EKFConfig(
            noise_jointpos=robot.noise_std
        ),  # the filter trusts the encoders as much as they deserve
        gui=not args.headless,
        port=args.port,
        duration=args.duration,
    )
    print(f"estimator: {app.session.estimator_name}")
    print(app.run())


if __name__ == "__main__":
    main()
