"""Going to hardware: drive your own `System` with the unchanged app, controller and GUI.

The app only talks to its plant through `judo.runtime.system.System`: `read_state()`, `apply(action)`,
`step()` and `reset()`. Here a stand-in "robot" implements it: an in-process cart-pole that is not
quite the model the controller plans with (its pole is 10% heavier), whose sensors are noisy and
arrive late, and whose motor takes a while to respond. Swap this class for one that talks to your
robot's drivers and nothing else changes.

    python examples/06_hardware_system.py                          # GUI at http://localhost:8080
    python examples/06_hardware_system.py --headless --duration 5  # prints a summary
"""

import argparse
from collections import deque

import mujoco
import numpy as np

import judo
from judo.runtime.system import System, SystemState
from judo.tasks.cartpole import MODEL_PATH


class LaggyNoisyCartpole(System):
    """A simulated cart-pole robot with sensor noise, sensor latency and actuation latency.

    Args:
        sensor_latency: seconds before a measurement reaches `read_state`.
        actuation_latency: seconds before an applied action reaches the motor.
        noise_std: std of the Gaussian noise on every measured [qpos, qvel] entry.
        pole_mass_scale: how much heavier the real pole is than in the planning model.
        seed: seeds the noise and the start state.
    """

    def __init__(
        self,
        sensor_latency: float = 0.02,
        actuation_latency: float = 0.01,
        noise_std: float = 0.005,
        pole_mass_scale: float = 1.1,
        seed: int = 0,
    ) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(MODEL_PATH))
        pole = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "pole")
        self.model.body_mass[pole] *= pole_mass_scale  # our own copy: the planner's model is untouched
        self.data = mujoco.MjData(self.model)
        self.timestep = float(self.model.opt.timestep)
        self.sensor_latency, self.actuation_latency, self.noise_std = sensor_latency, actuation_latency, noise_std
        self.rng = np.random.default_rng(seed)
        self._measurements: deque[tuple[float, np.ndarray]] = deque()  # (time taken, noisy state)
        self._commands: deque[tuple[float, np.ndarray]] = deque()  # (time due at the motor, action)
        self.reset()

    def reset(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = [0.0, np.pi] + self.rng.normal(0.0, 0.1, 2)  # pole hanging down
        mujoco.mj_forward(self.model, self.data)
        self._measurements.clear()
        self._commands.clear()
        self._measure()

    def read_state(self) -> SystemState:
        """The newest measurement that has arrived by now, stamped with the robot's clock."""
        now = self.data.time
        while len(self._measurements) > 1 and self._measurements[1][0] <= now - self.sensor_latency:
            self._measurements.popleft()
        return SystemState(self._measurements[0][1].copy(), now)

    def apply(self, action: np.ndarray) -> None:
        self._commands.append((self.data.time + self.actuation_latency, np.array(action, dtype=float)))

    def step(self) -> None:
        while self._commands and self._commands[0][0] <= self.data.time + 1e-9:
            self.data.ctrl[:] = self._commands.popleft()[1]
        mujoco.mj_step(self.model, self.data)
        self._measure()

    def _measure(self) -> None:
        state = np.concatenate([self.data.qpos, self.data.qvel])
        self._measurements.append((self.data.time, state + self.rng.normal(0.0, self.noise_std, state.shape)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--headless", action="store_true", help="run without the GUI")
    parser.add_argument("--duration", type=float, default=None, help="seconds of robot time to run")
    parser.add_argument("--port", type=int, default=8080, help="port of the GUI")
    args = parser.parse_args()
    robot = LaggyNoisyCartpole()
    app = judo.App(
        task="cartpole", optimizer="mppi", system=robot, gui=not args.headless, port=args.port, duration=args.duration
    )
    print(app.run())


if __name__ == "__main__":
    main()
