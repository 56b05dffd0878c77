"""Random pushes on a plant's body: a horizontal force held for a moment, at a fixed interval.

A task that must hold its robot up against disturbances owns one `RandomPushes` and calls `apply`
from its `pre_sim_step` (the plant only: the planning model never sees the push, as a robot's
planner never knows when it will be shoved). The force goes into the plant's `xfrc_applied` at the
body's centre of mass.
"""

import mujoco
import numpy as np


class RandomPushes:
    """Every `interval` seconds of plant time, push `body` horizontally with `force` newtons in a
    random direction for `duration` seconds. `count` is the number of pushes started since
    `reset`."""

    def __init__(self, model: mujoco.MjModel, body: str) -> None:
        self.body = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body))
        if self.body < 0:
            raise ValueError(f"no body {body!r} to push in the model")
        self.count = 0
        self._next = 0.0
        self._until = -1.0

    def reset(self, interval: float) -> None:
        """No push active; the first one `interval` seconds after plant time 0; the count at
        zero."""
        self.count = 0
        self._next = interval
        self._until = -1.0

    def apply(
        self,
        data: mujoco.MjData,
        rng: np.random.Generator,
        force: float,
        interval: float,
        duration: float,
    ) -> None:
        """Set the body's applied force for this step at `data.time`: start a push of `force` N in a
        direction drawn from `rng` when one is due (none while `force` or `interval` is not
        positive), hold it for `duration` s, then clear it."""
        now = float(data.time)
        if force > 0.0 and interval > 0.0 and now >= self._next:
            angle = rng.uniform(-np.pi, np.pi)
            data.xfrc_applied[self.body, :3] = (force * np.cos(angle), force * np.sin(angle), 0.0)
            self._until = now + duration
            self._next = now + interval
            self.count += 1
        elif now >= self._until:
            data.xfrc_applied[self.body, :3] = 0.0
