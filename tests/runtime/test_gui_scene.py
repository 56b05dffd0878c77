"""SceneView: every geom type drawn from a MuJoCo model, posed from the state; traces and
markers."""

from dataclasses import dataclass

import mujoco
import numpy as np
import pytest
import viser

import judo
from judo.core.configuration.config import Config
from judo.core.configuration.fields import np_1d_field
from judo.core.model import trace_sensor_columns
from judo.runtime.gui.camera import (
    FRAMING_FILL,
    VERTICAL_FOV,
    VISIBLE_ASPECT,
    distance_to_see,
    project,
)
from judo.runtime.gui.goal_handles import HANDLE_SCALE, HANDLE_SIZES, mocap_handle_size
from judo.runtime.gui.scene import SceneView, capsule_mesh, geom_box_corners, polyline_segments

XML = """
<mujoco>
  <asset>
    <mesh name="tetra" vertex="0 0 0  0.2 0 0  0 0.2 0  0 0 0.2"/>
    <material name="green" rgba="0 1 0 1"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.8 0.8 0.8 1"/>
    <geom name="hidden" type="box" size="0.1 0.1 0.1" group="3"/>
    <body name="slider" pos="0 0 0.5">
      <joint name="x" type="slide" axis="1 0 0"/>
      <geom name="ball" type="sphere" size="0.1" rgba="1 0 0 1"/>
      <geom name="egg" type="ellipsoid" size="0.1 0.2 0.3" pos="0.5 0 0" material="green"/>
      <geom name="rod" type="capsule" size="0.05 0.2" pos="-0.5 0 0" rgba="0 0 1 0.5"/>
      <geom name="can" type="cylinder" size="0.1 0.15" pos="0 0.5 0"/>
      <geom name="crate" type="box" size="0.1 0.2 0.3" pos="0 -0.5 0"/>
      <geom name="tetra" type="mesh" mesh="tetra" pos="0 0 0.5"/>
    </body>
    <body name="goal" mocap="true" pos="1 1 0">
      <geom type="sphere" size="0.05" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def server():
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server
    server.stop()


@pytest.fixture
def view(server):
    model = mujoco.MjModel.from_xml_string(XML)
    scene = SceneView(server.scene, model)
    yield scene
    scene.remove()


def geom(view: SceneView, name: str):
    return view.geom_nodes[mujoco.mj_name2id(view.model, mujoco.mjtObj.mjOBJ_GEOM, name)]


def test_every_visible_geom_type_becomes_its_viser_shape_with_its_colour(view):
    # a slab and grid lines under one frame
    assert isinstance(geom(view, "floor"), viser.FrameHandle)
    assert (
        isinstance(geom(view, "ball"), viser.IcosphereHandle) and geom(view, "ball").radius == 0.1
    )
    assert geom(view, "ball").color == (255, 0, 0)
    egg = geom(view, "egg")
    assert isinstance(egg, viser.IcosphereHandle) and egg.scale == (0.1, 0.2, 0.3)
    assert egg.color == (0, 255, 0)  # from its material
    rod = geom(view, "rod")
    assert isinstance(rod, viser.MeshHandle) and rod.opacity == 0.5
    can = geom(view, "can")
    assert isinstance(can, viser.CylinderHandle) and (can.radius, can.height) == (0.1, 0.3)
    assert isinstance(geom(view, "crate"), viser.BoxHandle)
    assert geom(view, "crate").dimensions == pytest.approx((0.2, 0.4, 0.6))
    tetra = geom(view, "tetra")
    assert (
        isinstance(tetra, viser.MeshHandle)
        and tetra.vertices.shape == (4, 3)
        and tetra.faces.shape == (4, 3)
    )
    hidden = mujoco.mj_name2id(view.model, mujoco.mjtObj.mjOBJ_GEOM, "hidden")
    assert hidden not in view.geom_nodes  # group 3: collision-only by convention
    # offset within its body frame
    np.testing.assert_allclose(geom(view, "egg").position, [0.5, 0, 0])


def test_update_poses_jointed_and_mocap_bodies(view):
    slider = mujoco.mj_name2id(view.model, mujoco.mjtObj.mjOBJ_BODY, "slider")
    goal = mujoco.mj_name2id(view.model, mujoco.mjtObj.mjOBJ_BODY, "goal")
    np.testing.assert_allclose(view.body_frames[goal].position, [1, 1, 0])
    view.update(
        np.array([0.7]),
        {"mocap_pos": np.array([[0.2, -0.3, 0.1]]), "mocap_quat": np.array([[1, 0, 0, 0]])},
    )
    np.testing.assert_allclose(view.body_frames[slider].position, [0.7, 0, 0.5])
    np.testing.assert_allclose(view.body_frames[goal].position, [0.2, -0.3, 0.1])


def test_camera_looks_at_the_solid_geoms_from_the_models_default_view(view):
    position, look_at = view.camera_pose()
    assert -0.5 < look_at[0] < 1.0 and look_at[2] > 0.0  # the bodies, not the 4 m floor
    direction = (look_at - position) / np.linalg.norm(look_at - position)
    # azimuth 90, elevation -45
    np.testing.assert_allclose(direction, [0, np.sqrt(0.5), -np.sqrt(0.5)], atol=1e-9)


CART_POLE = """
<mujoco>
  <worldbody>
    <body name="cart">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.02"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def framed_ndc(view: SceneView, points: np.ndarray) -> np.ndarray:
    """(n, 2) where `points` (n, 3) fall in the framing camera's view (|x|, |y| < 1 is inside)."""
    position, look_at = view.camera_pose()
    up = np.array([0.0, 0.0, 1.0])
    return np.array(
        [project(p, position, look_at, up, VERTICAL_FOV, VISIBLE_ASPECT) for p in points]
    )


def test_a_walker_is_framed_with_its_legs_reach_not_the_reach_of_its_sliding_root(server):
    """Framed tight about its standing pose, a walking walker's leg was cut at the edge of the view
    (issue 31); framed with where its slides could take it, it was a speck. Every pose of its legs
    and pitch around where the torso is now fits, and it still fills a fair share of the view."""
    model = judo.get_registered_tasks()["walker"][0]().model
    view = SceneView(server.scene, model)
    try:
        solid = [g for g in view.geom_nodes if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE]
        corners = geom_box_corners(model, view.data, solid)
        ndc = framed_ndc(view, corners)
        height = ndc[:, 1].max() - ndc[:, 1].min()  # of the view's 2 units
        assert height > 0.5, f"the walker fills only {height / 2:.0%} of the view's height"
        position, look_at = view.camera_pose()
        # metres; the root slides' reach framed it from 4.2
        assert np.linalg.norm(look_at - position) < 3.0
        rng = np.random.default_rng(0)
        low, high = model.jnt_range[3:].T  # the legs' hinges; the torso's pitch turns freely
        for _ in range(20):  # the legs and pitch anywhere in their ranges, the torso where it is
            qpos = view.data.qpos.copy()
            qpos[2], qpos[3:] = rng.uniform(-np.pi, np.pi), rng.uniform(low, high)
            posed = mujoco.MjData(model)
            posed.qpos[:] = qpos
            mujoco.mj_kinematics(model, posed)
            ndc = np.array(
                [
                    project(
                        p,
                        position,
                        look_at,
                        np.array([0.0, 0.0, 1.0]),
                        VERTICAL_FOV,
                        VISIBLE_ASPECT,
                    )
                    for p in geom_box_corners(model, posed, solid)
                ]
            )
            assert np.abs(ndc).max() < 1.0, f"a leg leaves the view at pose {np.round(qpos, 2)}"
        # walked 10 m (as a page opened mid-run sees it)
        view.update(np.r_[10.0, np.zeros(model.nq - 1)], {})
        far_position, far_look_at = view.camera_pose()
        np.testing.assert_allclose(far_look_at - look_at, [10.0, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(far_position - position, [10.0, 0.0, 0.0], atol=1e-9)
    finally:
        view.remove()


def test_a_pole_on_a_cart_is_framed_wherever_it_can_swing(server):
    view = SceneView(server.scene, mujoco.MjModel.from_xml_string(CART_POLE))
    try:
        # up, and out to each side
        swung = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
        assert np.abs(framed_ndc(view, swung)).max() < 1.0
    finally:
        view.remove()


def test_traces_become_line_segments_nominal_first(view, server):
    traces = np.zeros((3, 4, 2, 3))  # nominal + 2 rollouts, 4 steps, 2 trace sensors
    traces[..., 0] = np.arange(4)[None, :, None]
    view.set_traces(traces)
    nominal = server.scene.get_handle_by_name("/traces/nominal")
    samples = server.scene.get_handle_by_name("/traces/samples")
    assert nominal.points.shape == (2 * 3, 2, 3) and samples.points.shape == (2 * 2 * 3, 2, 3)
    view.set_traces(traces[:1])
    assert server.scene.get_handle_by_name("/traces/samples") is None


@dataclass
class GoalConfig(Config):
    goal: np.ndarray = np_1d_field([0.3, -0.2], vis_name="goal")
    """A 2-D goal, drawn at z = 0."""
    gains: np.ndarray = np_1d_field([1.0, 2.0, 3.0])
    """No vis_name: not drawn."""


def test_np_1d_fields_with_a_vis_name_get_a_marker_that_follows_the_config(view, server):
    view.set_markers(GoalConfig())
    marker = server.scene.get_handle_by_name("/markers/goal")
    np.testing.assert_allclose(marker.position, [0.3, -0.2, 0.0])
    view.set_markers(GoalConfig(goal=np.array([0.5, 0.5])))
    np.testing.assert_allclose(marker.position, [0.5, 0.5, 0.0])
    assert server.scene.get_handle_by_name("/markers/gains") is None


def test_capsule_mesh_is_closed_around_its_axis_with_outward_faces():
    vertices, faces = capsule_mesh(0.1, 0.3)
    assert np.abs(vertices[:, 2]).max() == pytest.approx(0.4)
    assert np.linalg.norm(vertices[:, :2], axis=1).max() == pytest.approx(0.1)
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    centres = (a + b + c) / 3
    # from the nearest point on the axis
    outward = centres - np.clip(centres * [0, 0, 1], -0.3, 0.3)
    areas = np.linalg.norm(normals, axis=1)
    proper = areas > 1e-12  # the pole rows give degenerate triangles
    assert (np.einsum("ij,ij->i", normals[proper], outward[proper]) > 0).all()


def test_polyline_segments_join_consecutive_steps_of_each_trace_and_sensor():
    traces = np.arange(2 * 3 * 1 * 3, dtype=float).reshape(2, 3, 1, 3)
    segments = polyline_segments(traces)
    assert segments.shape == (4, 2, 3)
    np.testing.assert_array_equal(segments[0], traces[0, :2, 0])
    np.testing.assert_array_equal(segments[3], traces[1, 1:, 0])
    assert polyline_segments(np.zeros((1, 1, 1, 3))).shape == (0, 2, 3)


def test_a_floor_the_robot_touches_is_drawn_under_it_wherever_it_walks(server):
    """MuJoCo's planes are infinite; walker's is drawn 50 m long and the walker walked off its end
    (issue 31). The drawn floor moves in whole grid sections, so its lines stay put in the world."""
    model = judo.get_registered_tasks()["walker"][0]().model
    view = SceneView(server.scene, model)
    try:
        ((floor, (frame, section)),) = view.floors.items()
        half_length = model.geom_size[floor, 0]
        for x in (0.0, 30.0, 140.0, -75.0):
            view.update(np.r_[x, np.zeros(model.nq - 1)], {})
            view.keep_floor_under(view.data.xpos[1])
            shift = np.asarray(frame.position)
            assert abs(x - shift[0]) <= half_length / 2, (
                f"the walker at x = {x} is near the drawn floor's end"
            )
            assert shift[0] / section == pytest.approx(round(shift[0] / section))
    finally:
        view.remove()


def test_a_floor_nothing_touches_stays_where_the_model_puts_it(server):
    # its table is drawn, not collided with
    model = judo.get_registered_tasks()["push_t"][0]().model
    view = SceneView(server.scene, model)
    try:
        assert view.floors == {}
    finally:
        view.remove()


def test_the_goal_cubes_drag_handle_is_smaller_than_the_goal_cube():
    """leap_cube's handle was bigger than its 7 cm goal cube and hid it (issue 31)."""
    model = judo.get_registered_tasks()["leap_cube"][0]().model
    goal = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "goal")
    half = model.geom_size[
        [g for g in range(model.ngeom) if model.geom_bodyid[g] == goal], :3
    ].max()
    size = mocap_handle_size(
        model, goal, float(np.clip(HANDLE_SCALE * model.stat.extent, *HANDLE_SIZES))
    )
    assert size < half, (
        f"the handle ({size:.3f} m) is not smaller than the goal cube's half-size ({half:.3f} m)"
    )


@pytest.mark.parametrize("task", ["quadruped_navigate", "particle", "fr3_pick"])
def test_a_small_goals_drag_handle_is_big_enough_to_grab_in_the_framed_view(server, task):
    """quadruped_navigate's handle was about 15 pixels (issue 43): now at least 4% of the framed
    view's height at the goal, about 40 pixels of a 900-pixel page."""
    model = judo.get_registered_tasks()[task][0]().model
    goal = int(np.flatnonzero(model.body_mocapid >= 0)[0])
    view = SceneView(server.scene, model)
    try:
        position, _ = view.camera_pose()
        distance = float(np.linalg.norm(view.data.xpos[goal] - position))
    finally:
        view.remove()
    size = mocap_handle_size(
        model, goal, float(np.clip(HANDLE_SCALE * model.stat.extent, *HANDLE_SIZES))
    )
    assert size / distance >= 0.04, (
        f"{task}: a {size:.3f} m handle {distance:.2f} m from the camera"
    )


def test_a_plans_traces_start_where_the_robot_is_drawn(server):
    """Foot traces were drawn beside the quadruped's feet (issue 43): a plan from a reading some
    tens of milliseconds old is drawn with each sensor's traces moved to start at the sensor as the
    scene poses it now."""
    controller = judo.make_controller("quadruped", "ps", num_workers=1)
    try:
        model = controller.task.model
        view = SceneView(server.scene, model)
        data = mujoco.MjData(model)
        if model.nkey:
            mujoco.mj_resetDataKeyframe(model, data, 0)
        state = np.r_[data.qpos, data.qvel]
        controller.update_action(state, 0.0)
        traces = controller.traces.copy()  # (1 + shown, T, 5, 3): torso and four feet
        moved = data.qpos.copy()
        moved[:2] += [0.1, -0.05]  # the robot as drawn now: 11 cm from where the plan started
        view.update(moved, {})
        # as the live GUI draws a plan (a replay draws it as recorded)
        view.set_traces(traces, anchored=True)
        # (segments, 2, 3), sensor by sensor
        nominal = server.scene.get_handle_by_name("/traces/nominal").points
        columns = trace_sensor_columns(model)
        sensors = [int(np.flatnonzero(model.sensor_adr == c)[0]) for c in columns[::3]]
        feet = [view.data.site_xpos[model.sensor_objid[s]] for s in sensors]
        # each sensor's first segment's first point
        starts = nominal.reshape(len(sensors), -1, 2, 3)[:, 0, 0]
        np.testing.assert_allclose(starts, feet, atol=1e-9)
        # unmoved, they were beside
        assert np.linalg.norm(traces[0, 0] - np.array(feet), axis=1).min() > 0.05
        view.remove()
    finally:
        controller.close()


def test_a_followed_camera_pulls_back_until_the_goal_is_in_view(server):
    """quadruped_navigate's goal was out of view in 2 of 4 frames (issue 43): following the robot,
    the camera keeps its direction and look-at and moves back just far enough for the goal to be
    inside the framed part of the view."""
    model = judo.get_registered_tasks()["quadruped_navigate"][0]().model
    view = SceneView(server.scene, model)
    try:
        position, look_at = view.camera_pose()
        offset = position - look_at
        up = np.array([0.0, 0.0, 1.0])
        near = look_at + [0.1, 0.0, 0.0]
        # kept
        assert distance_to_see(offset, look_at, near[None]) == pytest.approx(np.linalg.norm(offset))
        far = look_at + [6.0, 0.0, 0.0]  # a goal drawn 6 m to the side
        # out of view
        assert max(np.abs(project(far, position, look_at, up, VERTICAL_FOV, VISIBLE_ASPECT))) > 1.0
        distance = distance_to_see(offset, look_at, far[None])
        moved = look_at + offset * distance / np.linalg.norm(offset)
        seen = project(far, moved, look_at, up, VERTICAL_FOV, VISIBLE_ASPECT)
        assert max(np.abs(seen)) == pytest.approx(FRAMING_FILL)  # in view, at the framing's edge
        assert view.goal_positions().shape == (1, 3)  # the mocap goal
    finally:
        view.remove()
