"""Where a legged robot's floating base, joints, IMU and feet lie in its planning model and its
measured sensors: what the "legged" estimator reads, found once from the model and the task's
`measured_sensors`.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from judo.core.errors import ConfigError
from judo.core.model import names
from judo.core.task import Task

IMU_TYPES = ("framequat", "gyro", "accelerometer")
"""The IMU's measured sensor types, each at a site on the floating base."""


@dataclass(frozen=True)
class LeggedLayout:
    """The model facts the legged estimator uses.

    Attributes:
        base_qpos, base_qvel: the free joint's first qpos (7 wide) and qvel (6 wide) columns.
        joint_qpos, joint_qvel: (nj,) the qpos and qvel columns of every other joint (hinge or
            slide, 1 wide).
        joint_pos: (nj,) where each joint's jointpos value lies in the measured vector.
        joint_vel: (nj,) where each joint's jointvel value lies in the measured vector, or None when
            not all joints' velocities are measured (then they are differenced from the encoders).
        imu: {"framequat": slice, "gyro": slice, "accelerometer": slice} of the measured vector.
        imu_quat: (4,) [w, x, y, z] of the framequat sensor's site in the base body (the same for
            all three).
        feet: (k,) the foot sites' ids; foot_bodies: (k,) their bodies.
        ground_offset: (k,) each foot site's height above the floor when the foot stands flat on
            it (m), less how deep it sinks into the floor (`foot_sink`).
        touch: (k,) where each foot's touch sensor value lies in the measured vector, or None when
            not every foot has one (then a foot stands when it is near the lowest).
    """

    base_qpos: int
    base_qvel: int
    joint_qpos: np.ndarray
    joint_qvel: np.ndarray
    joint_pos: np.ndarray
    joint_vel: np.ndarray | None
    imu: dict[str, slice]
    imu_quat: np.ndarray
    feet: np.ndarray
    foot_bodies: np.ndarray
    ground_offset: np.ndarray
    touch: np.ndarray | None


def legged_layout(task: Task, foot_sites: tuple[str, ...], foot_sink: float | None) -> LeggedLayout:
    """The LeggedLayout of `task`'s planning model and measured sensors, with the feet sinking
    `foot_sink` m into the floor (None: as deep as in the model standing, `standing_sink`);
    ConfigError saying what is missing."""
    model, measured, owner = task.model, task.measured, type(task).__name__
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    if len(free) != 1:
        raise ConfigError(
            "the 'legged' estimator needs a model with one floating base (a free joint); "
            f"{owner}'s has {len(free)}"
        )
    base_body = int(model.jnt_bodyid[free[0]])
    others = [j for j in range(model.njnt) if j != free[0]]
    bad = [
        name_of(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        for j in others
        if model.jnt_type[j] not in (2, 3)
    ]
    if bad:
        raise ConfigError(
            f"the 'legged' estimator handles hinge and slide joints besides the base; {owner} "
            f"has {bad}"
        )

    def measured_of(sensor_type: str, objects: list[int]) -> list[int | None]:
        """Per object id, the start in the measured vector of the measured `sensor_type` sensor on
        it, or None."""
        found: dict[int, int] = {}
        for i, sensor_id in enumerate(measured.ids):
            if measured.types[i] == sensor_type:
                found.setdefault(int(model.sensor_objid[sensor_id]), measured.slices[i].start)
        return [found.get(o) for o in objects]

    joint_pos = measured_of("jointpos", others)
    missing = [
        name_of(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        for j, p in zip(others, joint_pos, strict=True)
        if p is None
    ]
    if missing:
        raise ConfigError(
            "the 'legged' estimator needs a jointpos sensor of every joint in "
            f"{owner}.measured_sensors; "
            f"none measures {', '.join(missing)}"
        )
    joint_vel = measured_of("jointvel", others)

    imu: dict[str, slice] = {}
    imu_sites: dict[str, int] = {}
    for i, sensor_id in enumerate(measured.ids):
        kind = measured.types[i]
        site = int(model.sensor_objid[sensor_id])
        on_site = (
            kind == "framequat" and model.sensor_objtype[sensor_id] == mujoco.mjtObj.mjOBJ_SITE
        )
        if kind in IMU_TYPES and kind not in imu and (on_site or kind != "framequat"):
            if model.site_bodyid[site] == base_body:
                imu[kind], imu_sites[kind] = measured.slices[i], site
    if len(imu) < len(IMU_TYPES) or len(set(imu_sites.values())) != 1:
        raise ConfigError(
            f"the 'legged' estimator needs an IMU ({', '.join(IMU_TYPES)}) at one site on "
            "the floating base in "
            f"{owner}.measured_sensors; it found {sorted(imu) or 'none'} "
            f"({', '.join(measured.names) or 'no sensors'})"
        )

    sites = foot_site_ids(task, foot_sites)
    touch = measured_of("touch", sites)
    offsets = np.array([ground_offset(model, s) for s in sites])
    sink = (
        standing_sink(model, np.array(sites), offsets)
        if foot_sink is None
        else np.full(len(sites), foot_sink)
    )
    return LeggedLayout(
        base_qpos=int(model.jnt_qposadr[free[0]]),
        base_qvel=int(model.jnt_dofadr[free[0]]),
        joint_qpos=np.array([model.jnt_qposadr[j] for j in others], dtype=int),
        joint_qvel=np.array([model.jnt_dofadr[j] for j in others], dtype=int),
        joint_pos=np.array(joint_pos, dtype=int),
        joint_vel=None if None in joint_vel else np.array(joint_vel, dtype=int),
        imu=imu,
        imu_quat=model.site_quat[imu_sites["framequat"]].copy(),
        feet=np.array(sites, dtype=int),
        foot_bodies=np.array([model.site_bodyid[s] for s in sites], dtype=int),
        ground_offset=offsets - sink,
        touch=None if None in touch else np.array(touch, dtype=int),
    )


def foot_site_ids(task: Task, foot_sites: tuple[str, ...]) -> list[int]:
    """The ids of the sites named `foot_sites`; when empty, the sites of the task's measured touch
    sensors, else the model's sites whose names end in "foot". ConfigError listing the sites when
    none is found or a name is not a site."""
    model, measured = task.model, task.measured
    all_sites = [n for n in names(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite) if n]
    if foot_sites:
        unknown = [n for n in foot_sites if n not in all_sites]
        if unknown:
            raise ConfigError(
                f"foot_sites {unknown} are not sites of {type(task).__name__}; its sites are "
                f"{all_sites}"
            )
        return [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, n) for n in foot_sites]
    touch = [
        int(model.sensor_objid[s])
        for s, t in zip(measured.ids, measured.types, strict=True)
        if t == "touch"
    ]
    if touch:
        return touch
    feet = [
        i
        for i in range(model.nsite)
        if (name_of(model, mujoco.mjtObj.mjOBJ_SITE, i) or "").endswith("foot")
    ]
    if not feet:
        raise ConfigError(
            f"the 'legged' estimator found no feet in {type(task).__name__}: no measured "
            "touch sensor and no site "
            f"named '*foot'; name them in LeggedConfig.foot_sites, from its sites {all_sites}"
        )
    return feet


def ground_offset(model: mujoco.MjModel, site: int) -> float:
    """The height (m) of `site` above the floor when its body stands flat on it (its z axis up):
    above the lowest point of the body's colliding geoms (a sphere's, capsule's or box's own;
    another geom's bounding sphere's), 0 without any."""
    body = int(model.site_bodyid[site])
    geoms = [int(g) for g in np.flatnonzero(model.geom_bodyid == body)]
    lowest = [lowest_point(model, g) for g in geoms if collides(model, g)]
    return float(model.site_pos[site, 2] - min(lowest)) if lowest else 0.0


STAND_KEY = "home"
"""The keyframe of the standing pose that `standing_sink` lets the model stand in."""
STAND_SECONDS = 1.0
"""How long `standing_sink` lets the model settle."""


def standing_sink(model: mujoco.MjModel, sites: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(k,) how deep (m) each foot site sinks below its (k,) `offsets` once the model has stood
    STAND_SECONDS from its STAND_KEY keyframe holding that pose's controls (a soft contact, or a
    rubber foot, gives way under the robot's weight); 0 for a foot off the floor there, and for
    every foot without such a keyframe."""
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, STAND_KEY)
    if key < 0:
        return np.zeros(len(sites))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    for _ in range(round(STAND_SECONDS / model.opt.timestep)):
        mujoco.mj_step(model, data)
    sink = offsets - data.site_xpos[sites, 2]
    return np.where((sink > 0) & (sink < offsets + 0.05), sink, 0.0)


def collides(model: mujoco.MjModel, geom: int) -> bool:
    return bool(model.geom_contype[geom] or model.geom_conaffinity[geom])


def lowest_point(model: mujoco.MjModel, geom: int) -> float:
    """The lowest z (m) of `geom` in its body's frame."""
    kind, size, pos = model.geom_type[geom], model.geom_size[geom], model.geom_pos[geom]
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
    z_row = rotation.reshape(3, 3)[2]  # the body-frame z of each of the geom's axes
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(pos[2] - size[0])
    if kind in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER):
        radius, half = size[0], size[1]
        disc = (
            radius * np.sqrt(max(0.0, 1.0 - z_row[2] ** 2))
            if kind == mujoco.mjtGeom.mjGEOM_CYLINDER
            else radius
        )
        return float(pos[2] - half * abs(z_row[2]) - disc)
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return float(pos[2] - np.abs(z_row * size).sum())
    return float(pos[2] - model.geom_rbound[geom])


def name_of(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, kind, index) or f"#{index}"
