"""The gait schedule of the legged tasks (quadruped, quadruped_velocity, quadruped_navigate and the
Unitree Go2's): `Gait` and the named `GAITS`, each foot's target height over its swing
(`swing_heights`), and the trot's clock the locomotion observation carries (`gait_clock`).
"""

from dataclasses import dataclass
from typing import Literal

import numpy as np

from judo.core.errors import ConfigError

LEGS = ("FR", "FL", "RR", "RL")
"""The quadruped's legs in actuator order, also the order of a gait's offsets: front right, front
left, rear right, rear left."""


@dataclass(frozen=True)
class Gait:
    """A periodic gait: each leg swings once per cycle, for 1 - duty of it, starting at its phase
    offset."""

    frequency: float
    """Cycles per second (Hz)."""
    duty: float
    """Share of the cycle each foot is on the floor."""
    offsets: tuple[float, float, float, float]
    """Where in the cycle (0 to 1) each leg's swing starts, legs in LEGS order."""


GAITS: dict[str, Gait] = {
    "trot": Gait(frequency=2.5, duty=0.5, offsets=(0.0, 0.5, 0.5, 0.0)),  # diagonal pairs together
    # one foot at a time: RL, FL, RR, FR
    "walk": Gait(frequency=1.25, duty=0.75, offsets=(0.75, 0.25, 0.5, 0.0)),
    "stand": Gait(frequency=1.0, duty=1.0, offsets=(0.0, 0.0, 0.0, 0.0)),  # every foot down
}
"""The gaits a config may name (QuadrupedConfig.gait)."""
GaitName = Literal["trot", "walk", "stand"]


def gait_of(name: str) -> Gait:
    """The Gait called `name`; raises ConfigError naming the gaits for any other name."""
    if name not in GAITS:
        raise ConfigError(f"unknown gait {name!r}; expected one of {list(GAITS)}")
    return GAITS[name]


CLOCK_HZ = GAITS["trot"].frequency
"""Frequency (Hz) of the clock in the locomotion observation: the trot's, so its phase is the
reward's schedule."""
CLOCK_RAD_PER_S = 2.0 * np.pi * CLOCK_HZ
"""The clock's phase rate (rad/s)."""


def gait_clock(times: np.ndarray) -> np.ndarray:
    """(B, 2) [cos, sin] of the trot's phase 2 pi CLOCK_HZ t at (B,) sim `times` (s): a front-right
    foot's swing starts at phase 0 (GAITS["trot"])."""
    phase = CLOCK_RAD_PER_S * np.asarray(times, dtype=float)
    return np.stack([np.cos(phase), np.sin(phase)], axis=1)


def swing_heights(times: np.ndarray, gait: Gait, step_height: float) -> np.ndarray:
    """(..., 4) target foot heights (m) at `times` (...) s: a half sine of `step_height` over each
    leg's swing, 0 while it stands."""
    if gait.duty >= 1.0:
        return np.zeros((*np.shape(times), len(LEGS)))
    phase = np.mod(np.asarray(times)[..., None] * gait.frequency + np.asarray(gait.offsets), 1.0)
    swing = phase / (1.0 - gait.duty)
    return np.where(swing < 1.0, step_height * np.sin(np.pi * np.minimum(swing, 1.0)), 0.0)
