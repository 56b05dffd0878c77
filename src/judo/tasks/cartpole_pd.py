"""Cart-pole swing-up planned through a low-level policy: the MPC plans the cart's target position,
and a PD law (an ONNX graph this module writes, nothing downloaded) turns target and state into the
push, every 2 steps.

The same hierarchy as a quadruped planned over its locomotion policy (judo.core.rollouts.low_level),
on a model small enough to test: the rollouts and the simulated plant both run the policy on
onnxruntime (a core dependency).
"""

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

import numpy as np

from judo.core.errors import import_extra
from judo.core.policies.onnx_policy import OnnxPolicy, write_linear_policy
from judo.core.rollouts.low_level import LowLevel
from judo.tasks.cartpole import MODEL_PATH, Cartpole

KP = 2.0
"""Push (ctrl, 10 N per unit) per metre of target error: 20 N/m on the 1.1 kg cart and pole."""
KD = 0.6
"""Push per m/s of cart velocity: 6 N s/m, about 0.6 of critical damping."""
EVERY = 2
"""Physics steps per policy tick: 50 Hz on the model's 100 Hz, a robot's usual low-level rate."""
TARGET_RANGE = (-1.8, 1.8)
"""Cart targets the MPC may plan (m); the rail ends at +-2."""
OBSERVATION = "target, cart x, pole angle, cart velocity, pole velocity"
"""The policy's observation, [command, qpos, qvel]: the LowLevel default."""


def pd_weight(kp: float = KP, kd: float = KD) -> np.ndarray:
    """(1, 5) the PD law on [target, x, angle, x_vel, angle_vel]: push = kp (target - x) - kd
    x_vel."""
    return np.array([[kp, -kp, 0.0, -kd, 0.0]])


@functools.cache
def pd_policy_path(kp: float = KP, kd: float = KD) -> Path:
    """The PD law as an ONNX file, written once per process (and set of gains) into a temporary
    directory that is removed at exit."""
    directory = Path(tempfile.mkdtemp(prefix="judo-cartpole-pd-"))
    atexit.register(shutil.rmtree, directory, True)
    metadata = {
        "name": "cartpole_pd_law",
        "task": "cartpole_pd",
        "kind": "action",
        "observation": OBSERVATION,
    }
    return write_linear_policy(directory / "pd.onnx", pd_weight(kp, kd), metadata=metadata)


class CartpolePD(Cartpole):
    """The cartpole task (its reward, reset and metrics) with one planned command, the cart's target
    position in TARGET_RANGE, which the PD policy turns into the push every EVERY steps. The
    reward's `controls` are the targets, so its control weight keeps them near the centre."""

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        feature = "task cartpole_pd (its PD policy, written and run with onnx)"
        # the PD law is written as ONNX before onnxruntime loads it
        import_extra("onnx", feature, "policy")
        self._low_level = LowLevel(
            OnnxPolicy(pd_policy_path(), feature=feature), command_range=[TARGET_RANGE], every=EVERY
        )

    def low_level(self) -> LowLevel:
        return self._low_level

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(1,) the first plan targets the cart where it is."""
        return np.clip(state[:1], *TARGET_RANGE)

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """(1,) hold the cart where it is: the PD law brakes it there."""
        return np.clip(state[:1], *TARGET_RANGE)
