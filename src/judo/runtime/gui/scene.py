"""The 3-D view: the MuJoCo model's geoms as viser nodes, posed from the plant state, plus traces
and markers.

Each body is a viser frame; its geoms are children at their fixed offsets, so a frame costs one pose
update however many geoms it holds. Only bodies that can move (jointed or mocap) are updated.
"""

import logging
from typing import Any

import mujoco
import numpy as np
import viser

from judo.core.configuration.config import Config
from judo.core.configuration.fields import array_field_spec
from judo.core.model import trace_sensor_columns
from judo.runtime.gui.camera import frame_points, model_camera, reach_points

logger = logging.getLogger("judo.gui")

Geom = mujoco.mjtGeom
VISIBLE_GROUPS = 3
"""Geoms in groups 0-2 are drawn, as in MuJoCo's viewer; higher groups are usually
collision-only."""
DEFAULT_GEOM_RGBA = (0.5, 0.5, 0.5, 1.0)
NOMINAL_TRACE_RGB = (0.9, 0.1, 0.1)
SAMPLE_TRACE_RGB = (0.1, 0.5, 0.9)
MARKER_RGB = (0.1, 0.8, 0.2)
GHOST_RGB = (0.2, 0.6, 1.0)
GHOST_OPACITY = 0.35
"""Colour and opacity of the estimate's ghost: the jointed bodies drawn again, translucent and
blue."""


class SceneView:
    """Draws `model` under the scene node `root` and keeps it posed from plant readings.

    With `ghost`, only the jointed bodies are drawn, translucent in GHOST_RGB, under `root` (e.g.
    "/ghost"): the robot as an estimator believes it is, posed beside the true one.

    Attributes:
        body_frames: body id -> viser frame, for every body that holds a drawn geom or is a mocap
            body.
        geom_nodes: geom id -> viser node, for every drawn geom.
        markers: vis_name -> the sphere drawn at a config's goal (see `set_markers`).
        floors: geom id -> (the frame its slab and grid hang from, its grid section in metres), for
            every world plane the robot can touch (see `keep_floor_under`).
    """

    def __init__(
        self,
        scene: viser.SceneApi,
        model: mujoco.MjModel,
        root: str = "/model",
        ghost: bool = False,
    ) -> None:
        self.scene, self.model, self.root, self.ghost = scene, model, root, ghost
        self.data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, self.data)
        self.body_frames: dict[int, Any] = {}
        self.geom_nodes: dict[int, Any] = {}
        self.markers: dict[str, Any] = {}
        self.floors: dict[int, tuple[Any, float]] = {}
        columns = trace_sensor_columns(model)  # the traces' sensors, in the order of their columns
        self._trace_sensors = [int(np.flatnonzero(model.sensor_adr == c)[0]) for c in columns[::3]]
        jointed = [b for b in range(1, model.nbody) if model.body_weldid[b] != 0]
        self._moving = (
            jointed
            if ghost
            else [b for b in range(1, model.nbody) if b in jointed or model.body_mocapid[b] >= 0]
        )
        for g in range(model.ngeom):
            rgba = geom_rgba(model, g)
            if model.geom_group[g] >= VISIBLE_GROUPS or rgba[3] == 0:
                continue
            body = int(model.geom_bodyid[g])
            if ghost:
                if model.body_weldid[body] == 0:
                    continue
                rgba = np.array([*GHOST_RGB, GHOST_OPACITY])
            node = self._add_geom(f"{self._frame(body)}/geom_{g}", g, rgba)
            if node is not None:
                self.geom_nodes[g] = node
        for b in range(1, model.nbody):
            if model.body_mocapid[b] >= 0 and not ghost:
                self._frame(b)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,), look_at (3,)) of a camera that frames the task as posed by the last
        `update`.

        The model's first camera when it has one (looking at the framed centre's depth); otherwise
        the drawn geoms (planes aside), the markers, and the reach of the jointed chains fixed to
        the world, seen from the model's default azimuth and elevation (see `camera.frame_points`).
        """
        model, data = self.model, self.data
        solid = [g for g in self.geom_nodes if model.geom_type[g] != Geom.mjGEOM_PLANE]
        corners = (
            geom_box_corners(model, data, solid) if solid else np.array(model.stat.center)[None]
        )
        corner_bodies = np.repeat(model.geom_bodyid[solid], 8) if solid else np.zeros(1, dtype=int)
        points = [corners, reach_points(model, data, corners, corner_bodies)]
        points += [np.asarray(marker.position)[None] for marker in self.markers.values()]
        position, look_at = frame_points(model, np.concatenate(points))
        named = model_camera(model, data, float(np.linalg.norm(look_at - position)))
        return named if named is not None else (position, look_at)

    def update(self, qpos: np.ndarray, metadata: dict[str, Any]) -> None:
        """Pose the moving bodies for `qpos` (nq,) and the mocap poses in `metadata` (if
        present)."""
        data = self.data
        data.qpos[:] = qpos
        for key in ("mocap_pos", "mocap_quat"):
            if key in metadata and np.shape(metadata[key]) == getattr(data, key).shape:
                getattr(data, key)[:] = metadata[key]
        mujoco.mj_kinematics(self.model, data)
        for b in self._moving:
            frame = self.body_frames.get(b)
            if frame is not None:
                frame.position = data.xpos[b]
                frame.wxyz = data.xquat[b]

    def keep_floor_under(self, point: np.ndarray) -> None:
        """Shift each floor the robot can touch (a world plane that collides, which MuJoCo makes
        infinite) in whole grid sections so it stays under `point` (3,): a walker never walks off
        the drawn floor, and the grid lines stay where they were in the world."""
        for g, (frame, section) in self.floors.items():
            rotation = self.data.geom_xmat[g].reshape(3, 3)
            # in the plane's frame
            local = rotation.T @ (np.asarray(point, dtype=float) - self.data.geom_xpos[g])
            shift = section * np.round(local[:2] / section)
            if np.any(shift != np.asarray(frame.position)[:2]):
                frame.position = (float(shift[0]), float(shift[1]), 0.0)

    def set_traces(self, traces: np.ndarray, anchored: bool = False) -> None:
        """Draw (num_traces, T, num_sensors, 3) trace positions as polylines, index 0 (the nominal)
        in red.

        `anchored` moves each sensor's traces to start where the scene draws that sensor now (the
        live GUI: a plan is made from a reading some tens of milliseconds old, in which a trotting
        foot was centimetres from where it is drawn); a replay draws them as recorded."""
        traces = self._anchored(traces) if anchored else traces
        for index, (name, rgb, thickness) in enumerate(
            [("nominal", NOMINAL_TRACE_RGB, 0.012), ("samples", SAMPLE_TRACE_RGB, 0.005)]
        ):
            chosen = traces[:1] if index == 0 else traces[1:]
            points = polyline_segments(chosen)
            path = f"/traces/{name}"
            if len(points) == 0:
                self.scene.remove_by_name(path)
                continue
            self.scene.add_line_segments(path, points, rgb, thickness=thickness)

    def _anchored(self, traces: np.ndarray) -> np.ndarray:
        """`traces` (num_traces, T, num_sensors, 3) shifted per sensor so that each trace's first
        point is the sensor's position in the scene as posed (a framepos of a site, body or geom in
        the world frame)."""
        drawn = self._trace_positions()
        if traces.size == 0 or drawn is None or drawn.shape != traces.shape[2:]:
            return traces
        return traces + (drawn - traces[0, 0])[None, None]

    def _trace_positions(self) -> np.ndarray | None:
        """(num_trace_sensors, 3) where the trace sensors' objects are drawn now; None if one is not
        in the world frame or not of a site, body or geom."""
        model, data = self.model, self.data
        places = {
            mujoco.mjtObj.mjOBJ_SITE: data.site_xpos,
            mujoco.mjtObj.mjOBJ_BODY: data.xipos,
            mujoco.mjtObj.mjOBJ_XBODY: data.xpos,
            mujoco.mjtObj.mjOBJ_GEOM: data.geom_xpos,
        }
        positions = []
        for sensor in self._trace_sensors:
            where = places.get(mujoco.mjtObj(model.sensor_objtype[sensor]))
            if where is None or model.sensor_reftype[sensor] != mujoco.mjtObj.mjOBJ_UNKNOWN:
                return None
            positions.append(where[model.sensor_objid[sensor]])
        return np.array(positions).reshape(-1, 3)

    def goal_positions(self) -> np.ndarray | None:
        """(n, 3) where the goals are drawn: the mocap bodies and the config's markers; None when
        there are none."""
        mocap = [
            self.data.xpos[b] for b in range(1, self.model.nbody) if self.model.body_mocapid[b] >= 0
        ]
        points = mocap + [
            np.asarray(marker.position, dtype=float) for marker in self.markers.values()
        ]
        return np.array(points).reshape(-1, 3) if points else None

    def set_markers(self, config: Config) -> None:
        """A sphere at the first three entries of every `np_1d_field` with a `vis_name` (missing
        ones are 0)."""
        for name, value in vars(config).items():
            spec = array_field_spec(type(config), name)
            if spec is None or spec.vis_name is None:
                continue
            position = np.zeros(3)
            entries = np.asarray(value, dtype=float)[:3]
            position[: len(entries)] = entries
            if spec.vis_name not in self.markers:
                radius = 0.04 * max(float(self.model.stat.extent), 1.0)
                self.markers[spec.vis_name] = self.scene.add_icosphere(
                    f"/markers/{spec.vis_name}", radius=radius, color=MARKER_RGB, position=position
                )
            else:
                self.markers[spec.vis_name].position = position

    def remove(self) -> None:
        """Take the model, traces and markers out of the scene (a ghost: only itself)."""
        for path in (self.root,) if self.ghost else (self.root, "/traces", "/markers"):
            self.scene.remove_by_name(path)

    # ---- building ------------------------------------------------------------------------------
    def _frame(self, body: int) -> str:
        path = f"{self.root}/body_{body}"
        if body not in self.body_frames:
            self.body_frames[body] = self.scene.add_frame(
                path, show_axes=False, position=self.data.xpos[body], wxyz=self.data.xquat[body]
            )
        return path

    def _add_geom(self, path: str, g: int, rgba: np.ndarray) -> Any:
        model, scene = self.model, self.scene
        size = model.geom_size[g]
        pose = {"position": model.geom_pos[g], "wxyz": model.geom_quat[g]}
        color, opacity = tuple(rgba[:3]), (None if rgba[3] >= 1 else float(rgba[3]))
        kind = model.geom_type[g]
        if kind == Geom.mjGEOM_PLANE:  # a thin slab just below the plane, with grid lines on it
            width = 2 * size[0] if size[0] > 0 else 20.0
            height = 2 * size[1] if size[1] > 0 else 20.0
            node = scene.add_frame(path, show_axes=False, **pose)
            section = max(width, height) / 4
            if model.geom_bodyid[g] == 0 and (model.geom_contype[g] or model.geom_conaffinity[g]):
                # MuJoCo's planes are infinite: a floor the robot can touch is drawn under it
                # wherever it goes
                self.floors[g] = (scene.add_frame(f"{path}/floor", show_axes=False), section)
                path = f"{path}/floor"
            # the grid draws the shadows: a slab taking them too speckled the floor with shadow acne
            scene.add_box(
                f"{path}/slab",
                color=color,
                dimensions=(width, height, 0.01),
                opacity=opacity,
                position=(0, 0, -0.005),
                receive_shadow=False,
            )
            scene.add_grid(
                f"{path}/grid",
                width=width,
                height=height,
                plane_opacity=0.0,
                cell_size=section / 4,
                section_size=section,
                position=(0, 0, 0.001),
            )
            return node
        if kind == Geom.mjGEOM_SPHERE:
            return scene.add_icosphere(
                path, radius=float(size[0]), color=color, opacity=opacity, **pose
            )
        if kind == Geom.mjGEOM_ELLIPSOID:
            return scene.add_icosphere(
                path,
                radius=1.0,
                scale=(float(size[0]), float(size[1]), float(size[2])),
                color=color,
                opacity=opacity,
                **pose,
            )
        if kind == Geom.mjGEOM_CYLINDER:
            return scene.add_cylinder(
                path,
                radius=float(size[0]),
                height=2 * float(size[1]),
                color=color,
                opacity=opacity,
                **pose,
            )
        if kind == Geom.mjGEOM_BOX:
            return scene.add_box(path, color=color, dimensions=2 * size, opacity=opacity, **pose)
        if kind == Geom.mjGEOM_CAPSULE:
            vertices, faces = capsule_mesh(float(size[0]), float(size[1]))
            return scene.add_mesh_simple(
                path, vertices, faces, color=color, opacity=opacity, **pose
            )
        if kind == Geom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
            vertices, faces = model.mesh_vert[v0 : v0 + nv], model.mesh_face[f0 : f0 + nf]
            return scene.add_mesh_simple(
                path, vertices, faces, color=color, opacity=opacity, **pose
            )
        logger.info("geom %d of type %s is not drawn", g, Geom(kind).name)
        return None


def geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """(4,) colour of geom `g`: its material's when it has one and kept the default geom colour."""
    rgba = model.geom_rgba[g]
    material = model.geom_matid[g]
    if material >= 0 and np.allclose(rgba, DEFAULT_GEOM_RGBA):
        return model.mat_rgba[material].copy()
    return rgba.copy()


def geom_box_corners(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int]) -> np.ndarray:
    """(8 * len(geoms), 3) world positions of the corners of each geom's bounding box
    (`geom_aabb`)."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    aabb = model.geom_aabb[geoms]  # (n, 6): centre and half sizes in the geom frame
    local = aabb[:, None, :3] + signs[None] * aabb[:, None, 3:]  # (n, 8, 3)
    rotations = data.geom_xmat[geoms].reshape(-1, 3, 3)
    return (np.einsum("nij,nkj->nki", rotations, local) + data.geom_xpos[geoms][:, None]).reshape(
        -1, 3
    )


def polyline_segments(traces: np.ndarray) -> np.ndarray:
    """(num_segments, 2, 3) start and end points joining consecutive steps of (num_traces, T,
    num_sensors, 3)."""
    if traces.ndim != 4 or traces.shape[1] < 2 or traces.shape[2] == 0:
        return np.zeros((0, 2, 3))
    # (num_traces * num_sensors, T, 3)
    paths = np.moveaxis(traces, 2, 1).reshape(-1, traces.shape[1], 3)
    segments = np.stack([paths[:, :-1], paths[:, 1:]], axis=2)
    return segments.reshape(-1, 2, 3)


def capsule_mesh(
    radius: float, half_length: float, rings: int = 6, segments: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 3), faces (F, 3)) of a capsule along z: hemispheres of `radius` at z =
    +-half_length.

    A latitude-longitude sphere whose upper rows are lifted by half_length and lower rows dropped by
    it; the band between the two equator rows is the cylinder. Faces wind counter-clockwise seen
    from outside.
    """
    theta = np.concatenate(
        [np.linspace(0, np.pi / 2, rings + 1), np.linspace(np.pi / 2, np.pi, rings + 1)]
    )
    lift = np.where(np.arange(len(theta)) <= rings, half_length, -half_length)
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    sin_t, cos_t = np.sin(theta)[:, None], np.cos(theta)[:, None]
    vertices = np.stack(
        [
            radius * sin_t * np.cos(phi),
            radius * sin_t * np.sin(phi),
            np.broadcast_to(radius * cos_t + lift[:, None], (len(theta), segments)),
        ],
        axis=-1,
    ).reshape(-1, 3)
    row, col = np.meshgrid(np.arange(len(theta) - 1), np.arange(segments), indexing="ij")
    a = row * segments + col
    b = row * segments + (col + 1) % segments
    c, d = a + segments, b + segments
    faces = np.concatenate(
        [np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)]
    )
    return vertices, faces
