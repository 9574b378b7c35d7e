"""Scene helpers: quaternions, capsule meshes, arcs, polylines, distance colours, jog labels, plots."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cobotsafety.app import draw
from cobotsafety.app.jog import jog_velocity
from cobotsafety.app.scene_planar import limitation_outline
from cobotsafety.errors import CobotSafetyError
from cobotsafety.planar.limitations import JointLimit
from cobotsafety.planar.planar_teleop import PlanarTeleop


@pytest.mark.parametrize("direction", [[1, 0, 0], [0, -1, 0], [0.3, 0.4, -0.5], [0, 0, -1], [0, 0, 1]])
def test_wxyz_z_to_turns_z_onto_direction(direction):
    w, x, y, z = draw.wxyz_z_to(np.array(direction, float))
    turned = Rotation.from_quat([x, y, z, w]).apply([0, 0, 1])
    np.testing.assert_allclose(turned, np.array(direction) / np.linalg.norm(direction), atol=1e-9)


@pytest.mark.parametrize("length_m, radius_m", [(0.3, 0.02), (0.0, 1.0), (1.0, 0.5)])
def test_capsule_mesh_is_a_closed_outward_capsule_by_trimesh(length_m, radius_m):
    """trimesh (the oracle) measures our numpy mesh: closed, consistently wound outward, the
    capsule's bounds, every vertex on the capsule's surface, the volume of an inscribed polyhedron."""
    import trimesh

    vertices, faces = draw.capsule_mesh(length_m, radius_m)
    assert vertices.dtype == np.float32 and faces.dtype == np.uint32
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    np.testing.assert_allclose(mesh.bounds, [[-radius_m] * 2 + [-radius_m], [radius_m] * 2 + [length_m + radius_m]],
                               atol=1e-6)
    axial = np.clip(vertices[:, 2], 0.0, length_m)  # distance of each vertex to the axis segment
    surface = np.hypot(np.hypot(vertices[:, 0], vertices[:, 1]), vertices[:, 2] - axial)
    np.testing.assert_allclose(surface, radius_m, atol=1e-6)  # float32 vertices
    exact = np.pi * radius_m**2 * length_m + 4.0 / 3.0 * np.pi * radius_m**3
    assert 0.93 * exact < mesh.volume < exact  # positive: outward; below: inscribed


def test_tube_mesh_is_an_open_unit_cylinder_facing_out():
    import trimesh

    mesh = trimesh.Trimesh(*draw.tube_mesh(), process=False)
    np.testing.assert_allclose(mesh.bounds, [[-1, -1, 0], [1, 1, 1]], atol=1e-6)
    radial = np.einsum("ij,ij->i", mesh.triangles_center[:, :2], mesh.face_normals[:, :2])
    assert (radial > 0).all()


def test_arc_points_turn_by_the_right_hand_rule_about_the_axis():
    points = draw.arc_points((1.0, 2.0, 3.0), (0.0, 0.0, 2.0), (5.0, 0.0, 1.0), 0.0, np.pi / 2, 0.1, count=3)
    np.testing.assert_allclose(points, [[1.1, 2.0, 3.0], [1.0 + 0.1 / np.sqrt(2), 2.0 + 0.1 / np.sqrt(2), 3.0],
                                        [1.0, 2.1, 3.0]], atol=1e-12)


def test_sphere_wireframe_lies_on_the_sphere():
    segments = draw.sphere_wireframe((0.1, -0.2, 0.3), 0.7)
    np.testing.assert_allclose(np.linalg.norm(segments.reshape(-1, 3) - [0.1, -0.2, 0.3], axis=1), 0.7, atol=1e-12)


def test_closed_polyline_of_a_square():
    segments = draw.polyline_segments(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))
    assert segments.shape == (4, 2, 3)
    np.testing.assert_array_equal(segments[-1], [[0, 1, 0], [0, 0, 0]])


def test_distance_colours():
    assert draw.distance_colour(1.0) == draw.GREEN
    assert draw.distance_colour(0.1) == draw.RED
    assert draw.distance_colour(0.35) == draw.AMBER  # halfway between red (0.2) and amber (0.5)
    assert draw.distance_colour(None) == draw.GREY
    assert draw.distance_colour(float("nan")) == draw.GREY


def test_jog_labels():
    np.testing.assert_array_equal(jog_velocity("-y", 0.05, 2), [0.0, -0.05])
    np.testing.assert_array_equal(jog_velocity("+z", 0.1, 3), [0.0, 0.0, 0.1])
    for bad in ("+z", "x", "*x", "+xx"):
        with pytest.raises(CobotSafetyError, match="jog label"):
            jog_velocity(bad, 0.05, 2)


def test_joint_2_limit_drawn_at_the_reach_of_its_angles():
    teleop = PlanarTeleop()
    segments = limitation_outline(JointLimit("B", 2, 0.25, 2.6), teleop)
    radii = np.linalg.norm(segments[:, 0, :2], axis=1)
    # L1 = L2 = 0.3: r(theta2) = sqrt(0.18 + 0.18 cos theta2)
    expected = sorted({round(np.sqrt(0.18 + 0.18 * np.cos(a)), 9) for a in (0.25, 2.6)})
    np.testing.assert_allclose(sorted(set(np.round(radii, 9))), expected)


from hypothesis import example, given, settings
from hypothesis import strategies as st


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 1e-6))
@example([0.0, 2.89867584433006e-07, -1.0])  # found by hypothesis: 1 + dz cancelled near -z
@example([0.0, 0.0, -1.0])
@example([0.0, 6.254490556801607e-163, -0.125])  # found by hypothesis: the norm's squares underflowed
def test_closed_form_quaternion_is_a_unit_rotation_onto_any_direction(direction):
    """The per-frame closed form against scipy's rotation of +z (independent oracle)."""
    q = draw.wxyz_z_to(np.array(direction))
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
    turned = Rotation.from_quat([q[1], q[2], q[3], q[0]]).apply([0, 0, 1])
    np.testing.assert_allclose(turned, np.array(direction) / np.linalg.norm(direction), atol=1e-7)


def test_plot_history_starts_a_new_trace_when_time_goes_back():
    from cobotsafety.app.control_loop import LoopSnapshot
    from cobotsafety.app.plots import PlotHistory

    history = PlotHistory(samples=10)
    for t_s in (1.0, 2.0, 3.0, 0.5, 0.6):  # a reset at 3 s
        history.add(LoopSnapshot(t_s, 0, "off", None, np.zeros(3), np.zeros(2), False, {"rate_hz": 1.0}), 0.3)
    np.testing.assert_allclose(history.array("t_s"), [0.5, 0.6])


def test_distance_chart_range_holds_every_value_in_steps():
    from cobotsafety.app.plots import distance_range_mm

    assert distance_range_mm(np.array([np.nan, np.nan])) == (0.0, 1000.0)
    assert distance_range_mm(np.array([120.0, 900.0])) == (0.0, 1000.0)
    assert distance_range_mm(np.array([120.0, 1001.0, np.nan])) == (0.0, 1250.0)
    assert distance_range_mm(np.array([-19.0, 2600.0])) == (-250.0, 2750.0)
