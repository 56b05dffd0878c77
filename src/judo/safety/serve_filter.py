"""The last-line filter: every command the closed loop serves passes it, whatever the planner made
it.

`ServeFilter.filter`, in order:
1. a non-finite command, or a non-finite reading, is replaced by the task's safe action;
2. each rate-limited command moves at most its rate times the time since the previous served
   command;
3. each effort-capped actuator's command is clamped so that its force from the latest reading (the
   PD's kp (q_des - q) - kv dq for a position actuator) stays within the cap;
4. one MuJoCo step of the planning model from the latest reading under the command predicts the next
   state: if it takes a joint further beyond its position or velocity limit, the workspace frame
   further out of its box, or a capped geom's contact force over its cap, the task's safe action
   (effort-clamped) is served instead; where the safe action's own step crosses too (momentum a zero
   push cannot stop), the first corner of the command range whose step crosses nothing, else the
   candidate that crosses least. One step sees one step ahead: a position limit holds to within what
   the actuators can stop in a step, so pair it with a velocity limit (docs/safety.md).
Each limit that acted is a `LimitHit` (time, limit, value): kept in `hits` (the latest MAX_KEPT),
counted in `counts`, handed to the step's record, and told once on the log and in `status` when a
new limit starts acting.
"""

import collections
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import mujoco
import numpy as np

from judo.core.planner import Planner
from judo.core.task import Task
from judo.safety.config import SafetyConfig
from judo.safety.feasibility import TOLERANCE, RolloutScreen
from judo.safety.limits import Limits, resolve

LOG = logging.getLogger("judo.safety")


@runtime_checkable
class ScreensRollouts(Protocol):
    """A planner that screens its rollouts before ranking them (a Controller's `limits`); a policy
    rolls nothing out."""

    limits: Any


MAX_KEPT = 10_000
"""Latest hits kept in `ServeFilter.hits` (a loop that runs for days counts every hit in
`counts`)."""


@dataclass(frozen=True)
class LimitHit:
    """One limit acting on one served command.

    Attributes:
        time: plant time of the command, in seconds.
        limit: which limit: "effort:ACTUATOR", "rate:ACTUATOR", "position:JOINT", "velocity:JOINT",
            "workspace:FRAME.x" (y, z), "contact:GEOM", "non-finite command" or "non-finite
            reading".
        value: what crossed it: the force or rate asked, the predicted position, speed or contact
            force (NaN for the non-finite ones).
    """

    time: float
    limit: str
    value: float


class ServeFilter:
    """Holds every served command of `task` within `limits` (see the module's docstring).

    Attributes:
        hits: the latest MAX_KEPT hits, oldest first; `step_hits` the latest command's.
        counts: hits by limit name, over the filter's life.
        filtered: commands filtered so far; `replaced` how many of them became the safe action.
        status: the latest line told ("safety: ... ; serving the safe action"), or None before any.
        screen: the planner's RolloutScreen where `safety_guard` set one (its counts join
            `summary`), else None.
    """

    def __init__(self, task: Task, limits: Limits) -> None:
        self.task, self.limits = task, limits
        self.model = task.model
        self.data = mujoco.MjData(self.model)
        self.nq = self.model.nq
        # One MuJoCo step needs actuator controls: under a low-level policy the commands are not
        # ctrl, so no prediction.
        wanted = (
            len(limits.position)
            or len(limits.velocity)
            or limits.workspace_frame
            or len(limits.contact_ids)
        )
        self._predicts = bool(wanted) and task.low_level() is None
        self.hits: collections.deque[LimitHit] = collections.deque(maxlen=MAX_KEPT)
        self.step_hits: tuple[LimitHit, ...] = ()
        self.counts: collections.Counter[str] = collections.Counter()
        self.filtered = self.replaced = 0
        self.status: str | None = None
        self.screen: RolloutScreen | None = None
        self._previous: np.ndarray | None = None
        self._previous_time = 0.0
        self._acting: frozenset[str] = frozenset()
        self._ctrl_low, self._ctrl_high = task.actuator_ctrlrange.T.copy()

    def restart(self) -> None:
        """Forget the previous command (after a reset of the plant): the next one is not
        rate-limited."""
        self._previous = None

    def filter(
        self,
        action: np.ndarray,
        state: np.ndarray | None,
        time: float,
        safe_action: Callable[[], np.ndarray],
        metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """(nu,) the command to serve at plant `time` instead of `action` (nu,), from the latest
        reading's (nq + nv,) `state` (None where the plant gives none: no effort clamp or
        prediction) and its `metadata` (its "mocap_pos"/"mocap_quat" pose the planning model's mocap
        bodies)."""
        hits: list[LimitHit] = []
        u = np.array(action, dtype=float)
        if not np.isfinite(u).all():
            hits.append(LimitHit(time, "non-finite command", float("nan")))
            u = np.array(safe_action(), dtype=float)
        if state is not None and not np.isfinite(state).all():
            hits.append(LimitHit(time, "non-finite reading", float("nan")))
            u, state = np.array(safe_action(), dtype=float), None
        if self._previous is not None and time >= self._previous_time and len(self.limits.rate):
            self._clamp_rate(u, time, hits)
        if state is not None:
            self._clamp_effort(u, state, time, hits)
            if self._predicts:
                crossed, _ = self._predict(u, state, time, metadata or {})
                if crossed:
                    hits += crossed
                    u = self._fallback(
                        np.array(safe_action(), dtype=float), state, time, metadata or {}
                    )
                    self.replaced += 1
        self.filtered += 1
        self._previous, self._previous_time = u, time
        # the next plan's first command is rate-checked against this one
        if self.screen is not None:
            self.screen.last_served = u
        self.step_hits = tuple(hits)
        self.hits.extend(hits)
        self.counts.update(hit.limit for hit in hits)
        acting = frozenset(hit.limit for hit in hits)
        if acting - self._acting:  # a limit started acting: tell it once
            replaced = any(
                h.limit.split(":")[0] in ("position", "velocity", "workspace", "contact")
                for h in hits
            )
            shown = ", ".join(f"{h.limit} {h.value:.4g}" for h in hits)
            self.status = f"safety at t={time:.3f} s: {shown}" + (
                "; serving the safe action" if replaced else "; clamped"
            )
            LOG.warning(self.status)
        self._acting = acting
        return u

    def _clamp_rate(self, u: np.ndarray, time: float, hits: list[LimitHit]) -> None:
        lim, dt = self.limits, time - self._previous_time
        assert self._previous is not None
        previous = self._previous[lim.rate_actuator]
        step = lim.rate_max * dt
        asked = u[lim.rate_actuator]
        held = np.minimum(np.maximum(asked, previous - step), previous + step)
        clamped = np.abs(asked - held) > TOLERANCE * np.maximum(1.0, np.abs(asked))
        if clamped.any():
            for k in np.flatnonzero(clamped):
                rate = abs(asked[k] - previous[k]) / dt if dt > 0 else float("inf")
                hits.append(LimitHit(time, f"rate:{lim.rate[k]}", float(rate)))
            u[lim.rate_actuator] = held

    def _clamp_effort(
        self, u: np.ndarray, state: np.ndarray, time: float, hits: list[LimitHit]
    ) -> None:
        lim = self.limits
        if not len(lim.effort):
            return
        qpos, qvel = state[: self.nq], state[self.nq :]
        force = lim.effort_of(u, qpos, qvel)
        over = np.abs(force) > lim.effort_max * (1 + TOLERANCE) + TOLERANCE
        if not over.any():
            return
        bias = force - lim.gain * u[lim.effort_actuator]
        # a zero gain: the command cannot change the force
        with np.errstate(divide="ignore", invalid="ignore"):
            ends = np.stack(
                [(-lim.effort_max - bias) / lim.gain, (lim.effort_max - bias) / lim.gain]
            )
        low, high = np.nanmin(ends, axis=0), np.nanmax(ends, axis=0)
        held = np.where(
            lim.gain != 0, np.clip(u[lim.effort_actuator], low, high), u[lim.effort_actuator]
        )
        for k in np.flatnonzero(over):
            hits.append(LimitHit(time, f"effort:{lim.effort[k]}", float(force[k])))
        u[lim.effort_actuator] = held

    def _fallback(
        self, safe: np.ndarray, state: np.ndarray, time: float, metadata: dict[str, Any]
    ) -> np.ndarray:
        """(nu,) what is served instead of a command predicted to cross a limit: the safe action
        (effort-clamped), unless its own prediction crosses one too (momentum a zero push cannot
        stop); then the first of the ctrlrange's two corners whose prediction crosses none, else the
        candidate predicted to cross least."""
        low, high = self.task.command_range.T
        best, least = safe, np.inf
        for candidate in (safe, low.copy(), high.copy()):
            self._clamp_effort(candidate, state, time, [])
            crossed, excess = self._predict(candidate, state, time, metadata)
            if not crossed:
                return candidate
            if excess < least:
                best, least = candidate, excess
        return best

    def _predict(
        self, u: np.ndarray, state: np.ndarray, time: float, metadata: dict[str, Any]
    ) -> tuple[list[LimitHit], float]:
        """The limits one step of the planning model from `state` under `u` takes further beyond
        (each a hit), and by how much in all (the sum of each one's growth beyond its limit)."""
        model, data, lim = self.model, self.data, self.limits
        data.qpos[:], data.qvel[:], data.time = state[: self.nq], state[self.nq :], time
        data.act[:] = 0.0
        data.ctrl[:] = np.minimum(np.maximum(u, self._ctrl_low), self._ctrl_high)
        for key, target in (("mocap_pos", data.mocap_pos), ("mocap_quat", data.mocap_quat)):
            if key in metadata and np.shape(metadata[key]) == target.shape:
                target[:] = metadata[key]
        # the data's kinematics stay those of `state`: the frame before the step
        mujoco.mj_step(model, data)
        before = self._frame(data) if lim.workspace_frame else None
        hits, excess = [], 0.0
        if len(lim.contact_ids):
            hits += self._contact_hits(time)
            excess += sum(h.value - lim.max_contact_force for h in hits)
        qpos, qvel = data.qpos, data.qvel
        q0, q1 = state[lim.position_index], qpos[lim.position_index]
        out0 = np.maximum(lim.position_low - q0, q0 - lim.position_high)
        out1 = np.maximum(lim.position_low - q1, q1 - lim.position_high)
        growth = out1 - np.maximum(out0, 0.0)
        if (growth > TOLERANCE).any():
            excess += float(growth[growth > TOLERANCE].sum())
            hits += [
                LimitHit(time, f"position:{lim.position[k]}", float(q1[k]))
                for k in np.flatnonzero(growth > TOLERANCE)
            ]
        v0, v1 = np.abs(state[self.nq :][lim.velocity_index]), np.abs(qvel[lim.velocity_index])
        growth = v1 - lim.velocity_max - np.maximum(v0 - lim.velocity_max, 0.0)
        if (growth > TOLERANCE).any():
            excess += float(growth[growth > TOLERANCE].sum())
            speeds = qvel[lim.velocity_index]
            hits += [
                LimitHit(time, f"velocity:{lim.velocity[k]}", float(speeds[k]))
                for k in np.flatnonzero(growth > TOLERANCE)
            ]
        if before is not None:
            mujoco.mj_kinematics(model, data)
            after = self._frame(data)
            out0 = np.maximum(lim.workspace_low - before, before - lim.workspace_high)
            out1 = np.maximum(lim.workspace_low - after, after - lim.workspace_high)
            growth = out1 - np.maximum(out0, 0.0)
            if (growth > TOLERANCE).any():
                excess += float(growth[growth > TOLERANCE].sum())
                frame = lim.workspace_frame
                hits += [
                    LimitHit(time, f"workspace:{frame}.{'xyz'[k]}", float(after[k]))
                    for k in np.flatnonzero(growth > TOLERANCE)
                ]
        return hits, excess

    def _frame(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) the workspace frame's world position in `data` (its kinematics computed)."""
        assert self.limits.frame_obj is not None
        obj, index = self.limits.frame_obj
        if obj == mujoco.mjtObj.mjOBJ_SITE:
            return data.site_xpos[index].copy()
        return (data.xipos if obj == mujoco.mjtObj.mjOBJ_BODY else data.xpos)[index].copy()

    def _contact_hits(self, time: float) -> list[LimitHit]:
        """A hit for each capped geom whose contacts' total normal force in the step just taken is
        over the cap."""
        data, lim = self.data, self.limits
        totals = dict.fromkeys(lim.contact_ids.tolist(), 0.0)
        wrench = np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            touched = [g for g in (contact.geom1, contact.geom2) if g in totals]
            if touched and contact.efc_address >= 0:
                mujoco.mj_contactForce(self.model, data, i, wrench)
                for g in touched:
                    totals[g] += abs(wrench[0])
        return [
            LimitHit(time, f"contact:{lim.contact_geoms[k]}", force)
            for k, (g, force) in enumerate(totals.items())
            if force > lim.max_contact_force * (1 + TOLERANCE)
        ]

    def summary(self) -> str:
        """One line: commands filtered, how many became the safe action, the hits by limit, and the
        planner's iterations with no feasible sample (where a screen is set)."""
        shown = ", ".join(f"{name} {count}" for name, count in self.counts.most_common()) or "none"
        line = (
            f"safety: {self.filtered} commands filtered, {self.replaced} replaced by the safe "
            f"action; limit hits: {shown}"
        )
        return line if self.screen is None else f"{line}; {self.screen.summary()}"


def safety_guard(planner: Planner, config: SafetyConfig | None) -> ServeFilter | None:
    """The serve filter of `config`'s limits on `planner`'s task, and the rollout screen set as a
    Controller's `limits` (a PolicyController rolls nothing out: the filter alone holds it), to hand
    to `ClosedLoop(guard=...)`; None, changing nothing, when `config` is None or sets no limit.
    LimitError for a limit the planning model cannot take."""
    if config is None or not config.active:
        return None
    task = planner.task
    limits = resolve(task, config)
    last_line = ServeFilter(task, limits)
    if isinstance(planner, ScreensRollouts):  # the planner says whether it rolls out
        planner.limits = last_line.screen = RolloutScreen(limits, task.dt, task.model.nq)
    return last_line
