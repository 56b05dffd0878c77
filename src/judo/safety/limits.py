"""The owner's limits resolved: `Limits`, a `SafetyConfig` (judo.safety.config: the `[safety.TASK]`
section of a config file, `--safety.*`) resolved against a task's planning model (indices, gains,
bounds), checked once at load.

Every entry names a joint, an actuator, a site, a body or a geom of the planning model; "*" in an
entry's name stands for every joint (velocity) or actuator (effort, rate). A config with no entry is
off: nothing is checked, planned or served differently (`SafetyConfig.active`).

The effort of an actuator is its force as MuJoCo computes it (`actuator_force`, before the gear):
for a gain and bias that are affine (motor, position, velocity and general actuators without
dynamics), force = gain0 * ctrl + bias0 + bias1 * length + bias2 * velocity, where length and
velocity are the joint's times the gear. A position actuator's force is so kp (q_des - q) - kv dq,
the torque its PD asks for.
"""

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from judo.core.errors import ConfigError
from judo.core.model import names
from judo.core.task import Task
from judo.safety.config import SafetyConfig, cap_entries, position_entries

ALL = "*"
"""The name that stands for every joint (velocity) or every actuator (effort, rate) in an entry."""
SCALAR_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
"""The joint types a position or velocity limit applies to (one qpos and one qvel each)."""
BASE = "base"
"""The workspace frame that means the first body with a free joint (its position is the joint's
qpos)."""


class LimitError(ConfigError):
    """A [safety] entry that does not fit the task's model (an unknown or unsuited joint, actuator,
    site or geom)."""


def _lookup(
    model: mujoco.MjModel, kind: str, obj: mujoco.mjtObj, count: int, name: str, valid: list[str]
) -> int:
    index = mujoco.mj_name2id(model, obj, name)
    if index < 0 or name not in valid:
        raise LimitError(
            f"safety limits: unknown {kind} {name!r}; valid {kind}s are: "
            f"{', '.join(valid) or 'none'}"
        )
    return index


@dataclass
class Limits:
    """A SafetyConfig resolved against a task's planning model. Arrays hold one entry per limit of
    their kind.

    Attributes:
        position: names (k,), qpos columns `position_index` (k,),
            bounds `position_low`, `position_high` (k,).
        velocity: names (m,), qvel columns `velocity_index` (m,), caps `velocity_max` (m,).
        effort: actuator names (e,), ids `effort_actuator` (e,), caps `effort_max` (e,), and each
            one's force
            terms: `gain` (e,) on ctrl, `bias` (e, 3) [constant, per length, per
                velocity], `gear` (e,) and the
            joint's qpos and qvel columns `effort_qpos`, `effort_qvel` (e,).
        rate: actuator names, ids `rate_actuator` and caps `rate_max` (r,) in command units per
            second.
        workspace_frame: the frame in the box ("" for none); `frame_qpos` (3,) its qpos columns (the
            base) or
            `frame_sensor` (3,) its framepos sensor's sensordata columns; `frame_obj` (mjtObj, id):
            a site (site_xpos), a body's inertial frame (xipos) or a body's frame (XBODY:
            xpos); `workspace_low`, `workspace_high` (3,).
        contact_geoms: geom names and ids `contact_ids` whose contact force is capped
            by `max_contact_force`.
    """

    position: list[str] = field(default_factory=list)
    position_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    position_low: np.ndarray = field(default_factory=lambda: np.zeros(0))
    position_high: np.ndarray = field(default_factory=lambda: np.zeros(0))
    velocity: list[str] = field(default_factory=list)
    velocity_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    velocity_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    effort: list[str] = field(default_factory=list)
    effort_actuator: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    effort_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    gain: np.ndarray = field(default_factory=lambda: np.zeros(0))
    bias: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    gear: np.ndarray = field(default_factory=lambda: np.zeros(0))
    effort_qpos: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    effort_qvel: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    rate: list[str] = field(default_factory=list)
    rate_actuator: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    rate_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    workspace_frame: str = ""
    frame_qpos: np.ndarray | None = None
    frame_sensor: np.ndarray | None = None
    frame_obj: tuple[mujoco.mjtObj, int] | None = None
    workspace_low: np.ndarray = field(default_factory=lambda: np.zeros(3))
    workspace_high: np.ndarray = field(default_factory=lambda: np.zeros(3))
    contact_geoms: list[str] = field(default_factory=list)
    contact_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    max_contact_force: float = 0.0

    def effort_of(self, ctrl: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """(..., e) the capped actuators' forces of controls (..., nu) in states whose qpos (...,
        nq), qvel (..., nv)."""
        length = self.gear * qpos[..., self.effort_qpos]
        speed = self.gear * qvel[..., self.effort_qvel]
        return (
            self.gain * ctrl[..., self.effort_actuator]
            + self.bias[:, 0]
            + self.bias[:, 1] * length
            + self.bias[:, 2] * speed
        )


def resolve(task: Task, config: SafetyConfig) -> Limits:
    """`config`'s limits on `task`'s planning model; LimitError (one line, naming the valid choices)
    for a name the model lacks or a joint or actuator the limit cannot apply to."""
    model, limits = task.model, Limits()
    joint_names = names(model, mujoco.mjtObj.mjOBJ_JOINT, model.njnt)
    scalar = [n for i, n in enumerate(joint_names) if n and int(model.jnt_type[i]) in SCALAR_JOINTS]
    bounds: dict[str, tuple[float, float]] = {}
    if config.joint_ranges:
        for name in scalar:
            j = joint_names.index(name)
            if model.jnt_limited[j]:
                low, high = model.jnt_range[j] + np.array(
                    [config.range_margin, -config.range_margin]
                )
                if low > high:
                    raise LimitError(
                        f"safety limits: range_margin {config.range_margin:g} is more than "
                        f"half of joint {name}'s range {model.jnt_range[j].tolist()}"
                    )
                bounds[name] = (float(low), float(high))
    for name, bound in position_entries(config.position).items():
        _lookup(model, "hinge or slide joint", mujoco.mjtObj.mjOBJ_JOINT, model.njnt, name, scalar)
        bounds[name] = bound
    limits.position = list(bounds)
    limits.position_index = np.array(
        [model.jnt_qposadr[joint_names.index(n)] for n in bounds], dtype=int
    )
    limits.position_low = np.array([b[0] for b in bounds.values()], dtype=float)
    limits.position_high = np.array([b[1] for b in bounds.values()], dtype=float)

    speeds = _expand(
        cap_entries("velocity", config.velocity),
        scalar,
        "hinge or slide joint",
        model,
        mujoco.mjtObj.mjOBJ_JOINT,
    )
    limits.velocity = list(speeds)
    limits.velocity_index = np.array(
        [model.jnt_dofadr[joint_names.index(n)] for n in speeds], dtype=int
    )
    limits.velocity_max = np.array(list(speeds.values()), dtype=float)

    actuators = names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu)
    for kind in ("effort", "rate"):
        if getattr(config, kind) and task.low_level() is not None:
            raise LimitError(
                f"safety limits: {kind} limits apply to actuators, but {type(task).__name__} "
                "plans a low-level policy's commands; use position, velocity or workspace "
                "limits"
            )
    caps = _expand(
        cap_entries("effort", config.effort),
        [a for a in actuators if a],
        "actuator",
        model,
        mujoco.mjtObj.mjOBJ_ACTUATOR,
    )
    ids = [actuators.index(n) for n in caps]
    for name, i in zip(caps, ids, strict=True):
        _check_affine(model, name, i)
    limits.effort, limits.effort_actuator = list(caps), np.array(ids, dtype=int)
    limits.effort_max = np.array(list(caps.values()), dtype=float)
    limits.gain = np.array([model.actuator_gainprm[i, 0] for i in ids], dtype=float)
    limits.bias = np.array([model.actuator_biasprm[i, :3] for i in ids], dtype=float).reshape(-1, 3)
    limits.gear = np.array([model.actuator_gear[i, 0] for i in ids], dtype=float)
    joints = [model.actuator_trnid[i, 0] for i in ids]
    limits.effort_qpos = np.array([model.jnt_qposadr[j] for j in joints], dtype=int)
    limits.effort_qvel = np.array([model.jnt_dofadr[j] for j in joints], dtype=int)

    rates = _expand(
        cap_entries("rate", config.rate),
        [a for a in actuators if a],
        "actuator",
        model,
        mujoco.mjtObj.mjOBJ_ACTUATOR,
    )
    limits.rate, limits.rate_actuator = (
        list(rates),
        np.array([actuators.index(n) for n in rates], dtype=int),
    )
    limits.rate_max = np.array(list(rates.values()), dtype=float)

    if config.workspace_frame:
        _resolve_frame(model, config.workspace_frame, limits)
        limits.workspace_low = np.asarray(config.workspace_low, dtype=float)
        limits.workspace_high = np.asarray(config.workspace_high, dtype=float)

    geoms = names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom)
    valid_geoms = [g for g in geoms if g]
    limits.contact_geoms = list(config.contact_geoms)
    limits.contact_ids = np.array(
        [
            _lookup(model, "geom", mujoco.mjtObj.mjOBJ_GEOM, model.ngeom, g, valid_geoms)
            for g in config.contact_geoms
        ],
        dtype=int,
    )
    limits.max_contact_force = config.max_contact_force
    return limits


def _expand(
    caps: dict[str, float], valid: list[str], kind: str, model: mujoco.MjModel, obj: mujoco.mjtObj
) -> dict[str, float]:
    """`caps` with "*" expanded to every valid name (a named entry wins over "*"); LimitError for an
    unknown name."""
    expanded = dict.fromkeys(valid, caps[ALL]) if ALL in caps else {}
    for name, cap in caps.items():
        if name != ALL:
            _lookup(model, kind, obj, len(valid), name, valid)
            expanded[name] = cap
    return expanded


def _check_affine(model: mujoco.MjModel, name: str, i: int) -> None:
    """LimitError unless actuator `i`'s force is affine in ctrl, length and velocity on one hinge or
    slide joint."""
    joint = model.actuator_trnid[i, 0]
    ok = (
        int(model.actuator_trntype[i]) == int(mujoco.mjtTrn.mjTRN_JOINT)
        and int(model.jnt_type[joint]) in SCALAR_JOINTS
        and int(model.actuator_dyntype[i]) == int(mujoco.mjtDyn.mjDYN_NONE)
        and int(model.actuator_gaintype[i]) == int(mujoco.mjtGain.mjGAIN_FIXED)
        and int(model.actuator_biastype[i])
        in (int(mujoco.mjtBias.mjBIAS_NONE), int(mujoco.mjtBias.mjBIAS_AFFINE))
    )
    if not ok:
        raise LimitError(
            f"safety limits: effort limit on actuator {name!r}: expected a joint actuator on "
            "a hinge or slide joint with a "
            "fixed gain, an affine bias and no dynamics (motor, position, velocity)"
        )


def _resolve_frame(model: mujoco.MjModel, frame: str, limits: Limits) -> None:
    """Set the workspace frame's columns: the base's qpos, or a framepos sensor's sensordata;
    LimitError listing the frames a rollout reports."""
    limits.workspace_frame = frame
    free = [
        j
        for j in range(model.njnt)
        if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE) and model.jnt_bodyid[j]
    ]
    valid = [BASE] if free and model.body_parentid[model.jnt_bodyid[free[0]]] == 0 else []
    sensors: dict[str, tuple[mujoco.mjtObj, int, int]] = {}
    for s in range(model.nsensor):
        if int(model.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_FRAMEPOS) and int(
            model.sensor_reftype[s]
        ) == int(mujoco.mjtObj.mjOBJ_UNKNOWN):
            obj = mujoco.mjtObj(int(model.sensor_objtype[s]))
            named = mujoco.mjtObj.mjOBJ_BODY if obj == mujoco.mjtObj.mjOBJ_XBODY else obj
            name = mujoco.mj_id2name(model, named, int(model.sensor_objid[s]))
            if (
                obj
                in (mujoco.mjtObj.mjOBJ_SITE, mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_XBODY)
                and name
            ):
                sensors.setdefault(
                    name, (obj, int(model.sensor_objid[s]), int(model.sensor_adr[s]))
                )
    valid += list(sensors)
    if frame not in valid:
        raise LimitError(
            f"safety limits: workspace_frame {frame!r} is neither the base nor a site or "
            "body a framepos sensor reports; "
            f"valid frames are: {', '.join(valid) or 'none (add a framepos sensor)'}"
        )
    if frame == BASE:
        adr = model.jnt_qposadr[free[0]]
        limits.frame_qpos = np.arange(adr, adr + 3)
        limits.frame_obj = (mujoco.mjtObj.mjOBJ_XBODY, int(model.jnt_bodyid[free[0]]))
    else:
        obj, objid, adr = sensors[frame]
        limits.frame_sensor = np.arange(adr, adr + 3)
        limits.frame_obj = (obj, objid)


SECTION_CONFIG = SafetyConfig
"""The class a config file's [safety.TASK] table sets the task's defaults of
(judo.core.configuration.config_file)."""


def check_section(task_name: str, config: SafetyConfig) -> None:
    """The load checks of a [safety.TASK] table against the task's planning model (`resolve`);
    LimitError if not."""
    if config.active:
        from judo.core.configuration.registry import make_task

        resolve(make_task(task_name), config)


def set_task_limits(task_name: str, given: dict[str, Any]) -> None:
    """Make `given` ({SafetyConfig field: value}, e.g. the `--safety.*` flags of the app and
    evaluate) the task's [safety] defaults in this process, over its own and the config file's;
    checked against its planning model first (ConfigError or LimitError, one line). Nothing changes
    for {}."""
    if not given:
        return
    from judo.core.configuration.config import with_updates
    from judo.core.configuration.registry import make_config, set_config_overrides

    check_section(task_name, with_updates(make_config(SafetyConfig, task_name), given))
    set_config_overrides(task_name, SafetyConfig, given)
