"""What MuJoCo Warp's overflow flags mean to a `WarpRollout` (core/rollouts/warp_rollout.py): the
bits that mean a world dropped contacts or constraint rows, how many times the buffers are doubled
before giving up, and the error and warning that say so.

Importing this module imports mujoco_warp (the `judo-mpc[warp]` extra).
"""

from judo.core.errors import JudoError, import_extra

FEATURE = "the warp rollout backend (--backend warp)"
mjw = import_extra("mujoco_warp", FEATURE, "warp")

CONTACT_OVERFLOWS = int(
    mjw.OverflowType.BROADPHASE | mjw.OverflowType.NARROWPHASE | mjw.OverflowType.CCD
)
"""Overflow bits meaning contacts were dropped: fixed by more contacts per world (nconmax)."""
CONSTRAINT_OVERFLOWS = int(mjw.OverflowType.NEFC | mjw.OverflowType.NJMAX_NNZ)
"""Overflow bits meaning constraint rows were dropped: fixed by more rows per world (njmax)."""
DROPPED = CONTACT_OVERFLOWS | CONSTRAINT_OVERFLOWS
"""Every overflow bit that means a rollout lost contacts or constraints (solver-iteration limits are
not such)."""
MAX_RESIZES = 8
"""Doublings of nconmax / njmax tried within one call before giving up with RolloutOverflowError."""


class RolloutOverflowError(JudoError):
    """Rollouts that still dropped contacts or constraints after the backend grew its buffers
    MAX_RESIZES times."""


class RolloutOverflowWarning(UserWarning):
    """A rollout overflowed its contact or constraint buffers; they were doubled and the batch
    rolled out again."""
