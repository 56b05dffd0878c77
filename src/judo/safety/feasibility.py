"""Rollout feasibility: a rollout that crosses a hard limit scores -inf before the optimizer sees
its reward.

The Controller calls `RolloutScreen.screen` on every iteration's rewards, whatever the optimizer,
the rollout backend (threads or GPU: the check reads the host arrays every backend returns) and a
policy's part (proposals are rows like any other; a low-level policy's rollouts are checked on their
states). It is vectorised numpy over (rows, T, ...), with no MuJoCo call.

When no sample of an iteration is feasible (the state already beyond a limit, or limits no sample
meets), the rewards become minus each sequence's total violation instead, so the optimizer moves
toward the limits, and the iteration is counted in `no_feasible`; the plan served then is the
least-violating one, and the serve filter (judo.safety.serve_filter) still holds the wire.
"""

import numpy as np

from judo.safety.limits import Limits

TOLERANCE = 1e-9
"""Relative slack of every check (a control clamped to a cap that equals the limit is within it)."""


class RolloutScreen:
    """Scores a batch of rollouts against `limits`.

    Args:
        limits: resolved on the planning model.
        dt: seconds between two rollout steps (the rate limits' time step).
        nq: the planning model's nq (states are [qpos, qvel]).

    Attributes:
        iterations: optimizer iterations screened.
        no_feasible: iterations in which no sample was feasible.
        infeasible: samples found infeasible, over all iterations.
        feasible_fraction: share of the last iteration's samples that were feasible.
        last_infeasible: (N,) bool, the last iteration's infeasible sequences.
        last_served: (nu,) the command the serve filter served last (it sets it), or None; where
            set, the rate limits' step before the rollouts' first is this one rather than the
            planner's (the plan in force).
    """

    def __init__(self, limits: Limits, dt: float, nq: int) -> None:
        self.limits, self.dt, self.nq = limits, dt, nq
        self.iterations = self.no_feasible = self.infeasible = 0
        self.feasible_fraction = 1.0
        self.last_infeasible = np.zeros(0, dtype=bool)
        self.last_served: np.ndarray | None = None

    def violations(
        self, states: np.ndarray, sensors: np.ndarray, controls: np.ndarray, served: np.ndarray
    ) -> np.ndarray:
        """(rows,) each rollout's total violation (0 where it keeps every limit), summed over the
        kinds of limit of each kind's largest excess along the rollout.

        Args:
            states: (rows, T, nq + nv) [qpos, qvel] after each step.
            sensors: (rows, T, nsensordata).
            controls: (rows, T, nu) the controls applied at each step.
            served: (nu,) the control served now, the step before the rollouts' first.
        """
        lim, rows = self.limits, len(states)
        total = np.zeros(rows)
        qpos, qvel = states[..., : self.nq], states[..., self.nq :]
        if len(lim.position):
            q = qpos[..., lim.position_index]
            total += _worst(
                np.maximum(lim.position_low - q, q - lim.position_high),
                lim.position_high - lim.position_low,
            )
        if len(lim.velocity):
            total += _worst(
                np.abs(qvel[..., lim.velocity_index]) - lim.velocity_max, lim.velocity_max
            )
        # the control of step t acts on the state before it: step t - 1's (the first's: step 0's)
        if len(lim.effort):
            before = np.concatenate([states[:, :1], states[:, :-1]], axis=1)
            force = lim.effort_of(controls, before[..., : self.nq], before[..., self.nq :])
            total += _worst(np.abs(force) - lim.effort_max, lim.effort_max)
        if len(lim.rate):
            served = served if self.last_served is None else self.last_served
            u = controls[..., lim.rate_actuator]
            steps = np.abs(
                np.diff(
                    u,
                    axis=1,
                    prepend=np.broadcast_to(served[lim.rate_actuator], (rows, 1, len(lim.rate))),
                )
            )
            total += _worst(steps / self.dt - lim.rate_max, lim.rate_max)
        if lim.workspace_frame:
            where = (
                qpos[..., lim.frame_qpos]
                if lim.frame_qpos is not None
                else sensors[..., lim.frame_sensor]
            )
            total += _worst(
                np.maximum(lim.workspace_low - where, where - lim.workspace_high),
                lim.workspace_high - lim.workspace_low,
            )
        return total

    def screen(
        self,
        rewards: np.ndarray,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        served: np.ndarray,
        num_models: int,
    ) -> np.ndarray:
        """(rows,) `rewards` with every infeasible sequence's rows set to -inf, rows being
        num_models blocks of the same sequences (a sequence infeasible under any model is
        infeasible); when none is feasible, minus each sequence's total violation instead. Arrays as
        in `violations`; rewards (rows,) is changed in place."""
        per_row = self.violations(states, sensors, controls, served)
        per_sequence = per_row.reshape(num_models, -1).max(axis=0)
        infeasible = self.last_infeasible = per_sequence > 0
        self.iterations += 1
        self.infeasible += int(infeasible.sum())
        self.feasible_fraction = 1.0 - float(infeasible.mean()) if len(infeasible) else 1.0
        if not infeasible.any():
            return rewards
        if infeasible.all():
            self.no_feasible += 1
            rewards[:] = np.tile(-per_sequence, num_models)
            return rewards
        rewards[np.tile(infeasible, num_models)] = -np.inf
        return rewards

    def summary(self) -> str:
        """One line: how many samples and iterations were infeasible."""
        return (
            f"planning: {self.no_feasible} of {self.iterations} iterations had no feasible sample "
            f"(the least-violating plan was served), {self.infeasible} infeasible samples"
        )


def _worst(excess: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """(rows,) the largest excess over a limit along each rollout (rows, T, k), 0 where within its
    tolerance."""
    slack = TOLERANCE * np.maximum(1.0, np.abs(scale))
    over = np.where(excess > slack, excess, 0.0)
    return over.reshape(len(over), -1).max(axis=1) if over.size else np.zeros(len(over))
