"""Where the GUI's camera looks: a framing of the task on open, reset and switch, and the focus body it follows.

    points = np.concatenate([corners, reach_points(model, data, corners, corner_bodies)])
    position, look_at = frame_points(model, points)            # (3,), (3,)
    follower = Follower(model, focus_body_id(model, task.focus_body))
    delta = follower.step(data)                                 # (3,) how far the focus moved

Framing uses the model's first camera when it has one; otherwise it looks, from the model's default
azimuth and elevation, at the box that holds the drawn geoms (planes aside) wherever the jointed
chains fixed to the world can swing them, from just far enough that it fits the view. A body that
slides or floats (a cart, a planar walker's torso) is framed where it is, not with every place it
could slide or swing its limbs to: the camera follows it instead.
"""

import mujoco
import numpy as np

MIN_FRAMED_RADIUS = 0.12
"""Metres: the smallest ball the camera frames, so a lone small body keeps a little context."""
FRAMING_MARGIN = 1.15
"""The framed ball is this much bigger than the bodies' extent, so nothing touches the edge."""
VERTICAL_FOV = np.deg2rad(75.0)
"""viser's default vertical field of view (radians)."""
VISIBLE_ASPECT = 1.2
"""Width over height of the part of a typical page the panel leaves uncovered."""


def focus_body_id(model: mujoco.MjModel, name: str | None) -> int:
    """The id of body `name`; without a name, the first body with a free joint, else 0 (no focus).

    Raises KeyError naming the bodies when `name` is not in the model.
    """
    if name is not None:
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if body < 0:
            bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)]
            raise KeyError(f"focus body {name!r} is not in the model; its bodies are {bodies}")
        return body
    for joint in range(model.njnt):
        if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
            return int(model.jnt_bodyid[joint])
    return 0


def reach_points(model: mujoco.MjModel, data: mujoco.MjData, corners: np.ndarray, corner_bodies: np.ndarray):
    """(6 * k, 3) points bounding where the k jointed chains fixed to the world can swing their geoms.

    A chain starts at a body that turns (hinge or ball joints only) on the world, or on bodies that
    only slide: a pendulum's pole, an arm's first link, the pole on a cart. Its reach is the ball
    around its first joint's anchor through its subtree's farthest geom corner, given as the ball's
    6 extreme points. A body that slides or floats (a cart, a pusher, a planar walker's torso, a
    free body) adds no reach: it is framed where it is and the camera follows it, rather than framed
    with where its slides start or every pose its limbs could swing to. `corners` (n, 3) are
    geom-box corners and `corner_bodies` (n,) the body each belongs to.
    """
    turning = {mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL}
    points = []
    for body in range(1, model.nbody):
        types = _joint_types(model, body)
        if not types or not types <= turning or not _slides_on_world(model, body):
            continue
        inside = np.array([_in_subtree(model, int(b), body) for b in corner_bodies], dtype=bool)
        if not inside.any():
            continue
        anchor = data.xanchor[model.body_jntadr[body]]
        radius = float(np.linalg.norm(corners[inside] - anchor, axis=1).max())
        points.append(anchor + radius * np.concatenate([np.eye(3), -np.eye(3)]))
    return np.concatenate(points) if points else np.zeros((0, 3))


def _joint_types(model: mujoco.MjModel, body: int) -> set[int]:
    first = model.body_jntadr[body]
    return {int(t) for t in model.jnt_type[first : first + model.body_jntnum[body]]}


def _slides_on_world(model: mujoco.MjModel, body: int) -> bool:
    """True when every body between `body` and the world has no joints or slide joints only."""
    parent = int(model.body_parentid[body])
    while parent > 0:
        if not _joint_types(model, parent) <= {mujoco.mjtJoint.mjJNT_SLIDE}:
            return False
        parent = int(model.body_parentid[parent])
    return True


def frame_points(model: mujoco.MjModel, points: np.ndarray, aspect: float = VISIBLE_ASPECT):
    """(position (3,), look_at (3,)) of a camera that sees every point of (n, 3) `points`.

    It looks at the centre of their box from the model's default azimuth and elevation
    (`<visual><global>`), far enough that the box's bounding ball fits both fields of view.
    """
    low, high = points.min(axis=0), points.max(axis=0)
    look_at = (low + high) / 2
    radius = FRAMING_MARGIN * max(0.5 * float(np.linalg.norm(high - low)), MIN_FRAMED_RADIUS)
    half_fov = min(VERTICAL_FOV / 2, np.arctan(np.tan(VERTICAL_FOV / 2) * aspect))
    distance = radius / np.sin(half_fov)
    azimuth, elevation = np.deg2rad([model.vis.global_.azimuth, model.vis.global_.elevation])
    forward = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    return look_at - distance * forward, look_at


def model_camera(model: mujoco.MjModel, data: mujoco.MjData, look_distance: float):
    """(position (3,), look_at (3,)) of the model's first camera, or None if it has none.

    MuJoCo cameras look along their -z axis; the look-at point is `look_distance` ahead.
    """
    if model.ncam == 0:
        return None
    position = data.cam_xpos[0].copy()
    forward = -data.cam_xmat[0].reshape(3, 3)[:, 2]
    return position, position + look_distance * forward


def project(point: np.ndarray, position: np.ndarray, look_at: np.ndarray, up: np.ndarray, fov: float, aspect: float):
    """(x, y) normalised device coordinates of `point` (3,) seen by a pinhole camera, or None if behind it.

    Both lie in [-1, 1] when the point is in view; `fov` is the vertical field of view in radians.
    """
    forward = look_at - position
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, up)
    right = right / np.linalg.norm(right)
    true_up = np.cross(right, forward)
    offset = np.asarray(point) - position
    depth = float(offset @ forward)
    if depth <= 0:
        return None
    scale = depth * np.tan(fov / 2)
    return float(offset @ right) / (scale * aspect), float(offset @ true_up) / scale


class Follower:
    """Tracks how far the focus body moved since the last `step` (nothing to follow for body 0)."""

    def __init__(self, model: mujoco.MjModel, body: int) -> None:
        self.model, self.body = model, body
        self._last: np.ndarray | None = None

    def restart(self, data: mujoco.MjData) -> None:
        """Take the focus body's position in `data` as the new reference (after a reframing)."""
        self._last = data.xpos[self.body].copy()

    def step(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) the focus body's displacement since the last call (zeros without a focus body)."""
        if self.body == 0:
            return np.zeros(3)
        now = data.xpos[self.body].copy()
        delta = np.zeros(3) if self._last is None else now - self._last
        self._last = now
        return delta


def _in_subtree(model: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = int(model.body_parentid[body])
    return False
