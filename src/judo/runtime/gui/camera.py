"""Where the GUI's camera looks: a framing of the task on open, reset and switch, and the focus body
it follows.

    points = np.concatenate([corners, reach_points(model, data, corners, corner_bodies)])
    position, look_at = frame_points(model, points)            # (3,), (3,)
    follower = Follower(model, focus_body_id(model, task.focus_body))
    delta = follower.step(data)                                 # (3,) how far the focus moved

Framing uses the model's first camera when it has one; otherwise it looks, from the model's default
azimuth and elevation, at the drawn geoms (planes aside) and everywhere the robot can swing them
without travelling: the reach of the jointed chains fixed to the world, and the reach of the limbs
of a body that slides or floats (a cart's pole, a walker's legs) around where that body is now.
The camera sits just far enough back that every such point lands inside the middle FRAMING_FILL of
the canvas, which the docked GUI panel does not cover. Where a body could slide to is not framed:
the camera follows it instead. `PageCameras` sends those poses to every open page and moves the
pages' cameras along with the focus body.
"""

import collections

import mujoco
import numpy as np
import viser

MIN_FRAMED_RADIUS = 0.12
"""Metres: the smallest half-extent the camera frames, so a lone small body keeps a little
context."""
FRAMING_FILL = 0.8
"""The framed points reach at most this fraction of the way from the view's centre to its edges."""
VERTICAL_FOV = np.deg2rad(75.0)
"""viser's default vertical field of view (radians)."""
VISIBLE_ASPECT = 1.1
"""Width over height of the canvas beside the docked GUI panel on a 1280 x 800 page (wider pages see
more)."""
SENT_POSES_KEPT = 400
"""Camera poses sent to the pages that a late camera report is matched against (a few seconds'
worth)."""


def focus_body_id(model: mujoco.MjModel, name: str | None) -> int:
    """The id of body `name`; without a name, the first body with a free joint, else 0 (no focus).

    Raises KeyError naming the bodies when `name` is not in the model.
    """
    if name is not None:
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if body < 0:
            bodies = [
                mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)
            ]
            raise KeyError(f"focus body {name!r} is not in the model; its bodies are {bodies}")
        return body
    for joint in range(model.njnt):
        if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
            return int(model.jnt_bodyid[joint])
    return 0


def reach_points(
    model: mujoco.MjModel, data: mujoco.MjData, corners: np.ndarray, corner_bodies: np.ndarray
):
    """(n, 3) points bounding where k bodies can swing their subtrees' geoms without travelling.

    Two kinds of body count. A chain that turns (hinge or ball joints only) on the world, or on
    bodies that only slide (a pendulum's pole, an arm's first link, the pole on a cart), reaches the
    ball around its first joint's anchor as far as its subtree can stretch. A body that slides or
    floats on the world (a cart, a pusher, a planar walker's torso, a free humanoid)
    reaches the ball around where it is now as far as its subtree can stretch: its limbs in any
    pose, but not every place it could slide to (the camera follows it instead). A ball is given as
    14 points on it; where every hinge below the body turns about one axis (a planar robot), the
    reach is the ball's circle across that axis, given as 16 points on it. `corners` (n, 3) are
    geom-box corners and `corner_bodies` (n,) the body each belongs to.
    """
    turning = {mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL}
    points = []
    for body in range(1, model.nbody):
        types = _joint_types(model, body)
        if not types or not _slides_on_world(model, body):
            continue
        inside = np.array([_in_subtree(model, int(b), body) for b in corner_bodies], dtype=bool)
        if not inside.any():
            continue
        centre = data.xanchor[model.body_jntadr[body]] if types <= turning else data.xpos[body]
        radius = _reach_radius(model, data, body, centre, corners, corner_bodies)
        axis = _swing_axis(model, data, body)
        points.append(
            centre + radius * (BALL_DIRECTIONS if axis is None else _circle_directions(axis))
        )
    return np.concatenate(points) if points else np.zeros((0, 3))


def _reach_radius(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    body: int,
    point: np.ndarray,
    corners: np.ndarray,
    corner_bodies: np.ndarray,
) -> float:
    """How far from `point` (3,), fixed in `body`, any geom corner of `body`'s subtree can get in
    any pose: `body`'s own corners, and for each jointed child the distance to its joint's anchor
    plus the child's own reach from there (a folded arm reaches as far as a straight one)."""
    own = corners[corner_bodies == body]
    radius = float(np.linalg.norm(own - point, axis=1).max()) if len(own) else 0.0
    for child in range(body + 1, model.nbody):
        if model.body_parentid[child] != body:
            continue
        if model.body_jntnum[child] == 0:  # welded on: it moves with `body`
            radius = max(radius, _reach_radius(model, data, child, point, corners, corner_bodies))
            continue
        anchor = data.xanchor[model.body_jntadr[child]]
        reach = _reach_radius(model, data, child, anchor, corners, corner_bodies)
        if reach > 0:
            radius = max(radius, float(np.linalg.norm(anchor - point)) + reach)
    return radius


BALL_DIRECTIONS = np.concatenate(
    [
        np.eye(3),
        -np.eye(3),
        np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) / np.sqrt(3),
    ]
)
"""(14, 3) unit directions whose points outline a ball well enough to frame it from any side."""


def _swing_axis(model: mujoco.MjModel, data: mujoco.MjData, body: int) -> np.ndarray | None:
    """(3,) the one world axis every hinge in `body`'s subtree turns about (a planar robot), or None
    when the subtree turns about several axes or has a ball or free joint."""
    axes = []
    for joint in range(model.njnt):
        if not _in_subtree(model, int(model.jnt_bodyid[joint]), body):
            continue
        kind = model.jnt_type[joint]
        if kind in (mujoco.mjtJoint.mjJNT_BALL, mujoco.mjtJoint.mjJNT_FREE):
            return None
        if kind == mujoco.mjtJoint.mjJNT_HINGE:
            axes.append(data.xaxis[joint] / np.linalg.norm(data.xaxis[joint]))
    if not axes or any(abs(float(a @ axes[0])) < 1 - 1e-6 for a in axes):
        return None
    return axes[0]


def _circle_directions(axis: np.ndarray, count: int = 16) -> np.ndarray:
    """(count, 3) unit directions around the circle perpendicular to `axis` (3,): a planar reach."""
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u = u / np.linalg.norm(u)
    v = np.cross(axis, u)
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v


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
    (`<visual><global>`), from just far enough that each point projects within FRAMING_FILL of the
    view's half-width and half-height (a pinhole of VERTICAL_FOV and width over height `aspect`).
    """
    low, high = points.min(axis=0), points.max(axis=0)
    look_at = (low + high) / 2
    azimuth, elevation = np.deg2rad([model.vis.global_.azimuth, model.vis.global_.elevation])
    forward = np.array(
        [
            np.cos(elevation) * np.cos(azimuth),
            np.cos(elevation) * np.sin(azimuth),
            np.sin(elevation),
        ]
    )
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right = (
        right / np.linalg.norm(right)
        if np.linalg.norm(right) > 1e-9
        else np.array([np.sin(azimuth), -np.cos(azimuth), 0.0])
    )
    up = np.cross(right, forward)
    offsets = points - look_at  # (n, 3)
    across, along, depth = np.abs(offsets @ right), np.abs(offsets @ up), offsets @ forward
    tan_y = FRAMING_FILL * np.tan(VERTICAL_FOV / 2)
    # (n,) each point's distance
    needed = np.maximum(across / (tan_y * aspect), along / tan_y) - depth
    distance = max(
        float(needed.max()),
        MIN_FRAMED_RADIUS / tan_y,
        float(np.abs(depth).max()) + MIN_FRAMED_RADIUS,
    )
    return look_at - distance * forward, look_at


def distance_to_see(
    offset: np.ndarray, look_at: np.ndarray, points: np.ndarray, aspect: float = VISIBLE_ASPECT
):
    """The camera's distance from `look_at` along its view, `offset` (3,) = position - look_at, kept
    unless some of (n, 3) `points` (the goals) would then project beyond FRAMING_FILL of the view:
    then the distance that brings them all within it. The view's direction and look-at stay (a zoom
    out, never in)."""
    distance = float(np.linalg.norm(offset))
    if len(points) == 0 or distance < 1e-9:
        return distance
    forward = -offset / distance
    right = np.cross(forward, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-9:  # looking straight down or up: any horizontal axis will do
        right = np.array([1.0, 0.0, 0.0])
    right = right / np.linalg.norm(right)
    up = np.cross(right, forward)
    offsets = np.asarray(points, dtype=float) - look_at
    across, along, depth = np.abs(offsets @ right), np.abs(offsets @ up), offsets @ forward
    tan_y = FRAMING_FILL * np.tan(VERTICAL_FOV / 2)
    # (n,) each point's distance
    needed = np.maximum(across / (tan_y * aspect), along / tan_y) - depth
    return max(distance, float(needed.max()))


def model_camera(model: mujoco.MjModel, data: mujoco.MjData, look_distance: float):
    """(position (3,), look_at (3,)) of the model's first camera, or None if it has none.

    MuJoCo cameras look along their -z axis; the look-at point is `look_distance` ahead.
    """
    if model.ncam == 0:
        return None
    position = data.cam_xpos[0].copy()
    forward = -data.cam_xmat[0].reshape(3, 3)[:, 2]
    return position, position + look_distance * forward


def project(
    point: np.ndarray,
    position: np.ndarray,
    look_at: np.ndarray,
    up: np.ndarray,
    fov: float,
    aspect: float,
):
    """(x, y) normalised device coordinates of `point` (3,) seen by a pinhole camera, or None if
    behind it.

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


class PageCameras:
    """The camera of every page open on `server`: framed on the task, and moved with the focus body.

    The look-at point is ours (a page's camera report may lag our last move, so it is not added to);
    the view direction and distance stay the page's own, so the user can still orbit and zoom.
    """

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        # where the cameras look while following: the framed centre plus the focus's moves
        self._look_at = np.zeros(3)
        # client id -> (3,) camera position minus look-at that we keep
        self._offsets: dict[int, np.ndarray] = {}
        # (2, 3) poses sent
        self._sent: collections.deque[np.ndarray] = collections.deque(maxlen=SENT_POSES_KEPT)

    def sent(self, client_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(position (3,), look_at (3,)) of the camera last sent to page `client_id` (None before
        any)."""
        offset = self._offsets.get(client_id)
        return None if offset is None else (self._look_at + offset, self._look_at.copy())

    def frame(self, position: np.ndarray, look_at: np.ndarray) -> None:
        """Point every page's camera (and a new page's) from `position` at `look_at`."""
        self.server.initial_camera.position = position
        self.server.initial_camera.look_at = look_at
        self._look_at = np.array(look_at, dtype=float)
        self._offsets.clear()
        for client in self.server.get_clients().values():
            with client.atomic():
                client.camera.position, client.camera.look_at = position, look_at
            self._offsets[client.client_id] = np.asarray(position, dtype=float) - look_at
        self._sent.append(
            np.stack([np.asarray(position, dtype=float), np.asarray(look_at, dtype=float)])
        )

    def frame_page(
        self, client: viser.ClientHandle, position: np.ndarray, look_at: np.ndarray
    ) -> None:
        """Point the camera of page `client` (opened mid-run) from `position` at `look_at`."""
        with client.atomic():
            client.camera.position, client.camera.look_at = position, look_at
        self._offsets[client.client_id] = np.asarray(position, dtype=float) - look_at
        self._sent.append(
            np.stack([np.asarray(position, dtype=float), np.asarray(look_at, dtype=float)])
        )

    def move(self, delta: np.ndarray) -> None:
        """Move the look-at point by `delta` (3,), how far the focus body moved (kept up while
        follow is off too, so turning follow on finds the focus)."""
        self._look_at = self._look_at + delta

    def follow(self, goals: np.ndarray | None) -> None:
        """Move every page's camera to the look-at point, pulled back until (n, 3) `goals` are in
        view too.

        A page that lags may report a camera halfway through our moves (a new look-at with a
        position we sent a second ago); taken as the user's view, that would drift the camera behind
        a walking robot. So a report whose position and look-at are both among the last poses we
        sent is ours, and the offset we keep stands; any other report is the user's orbit or zoom,
        and is kept.
        """
        # (n, 2, 3) position and look-at of each pose sent
        sent = np.array(self._sent).reshape(-1, 2, 3)
        for client in self.server.get_clients().values():
            camera = client.camera
            position, look_at = np.asarray(camera.position), np.asarray(camera.look_at)
            kept = self._offsets.get(client.client_id)
            ours = np.any(np.linalg.norm(sent[:, 0] - position, axis=1) < 1e-3) and np.any(
                np.linalg.norm(sent[:, 1] - look_at, axis=1) < 1e-3
            )
            offset = kept if kept is not None and ours else position - look_at
            if goals is not None:  # pull back until the goals are in view too
                length = float(np.linalg.norm(offset))
                offset = (
                    offset * (distance_to_see(offset, self._look_at, goals) / length)
                    if length
                    else offset
                )
            self._offsets[client.client_id] = offset
            self._sent.append(np.stack([self._look_at + offset, self._look_at]))
            with client.atomic():
                camera.position = self._look_at + offset
                camera.look_at = self._look_at
