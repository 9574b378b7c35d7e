"""Scene helpers: quaternions, capsule meshes, polylines, distance colours, jog labels."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cobotsafety.app import draw
from cobotsafety.app.jog import jog_velocity
from cobotsafety.app.panel import status_text
from cobotsafety.app.scene_planar import limitation_outline
from cobotsafety.errors import CobotSafetyError
from cobotsafety.planar.limitations import JointLimit
from cobotsafety.planar.planar_teleop import PlanarTeleop


@pytest.mark.parametrize("direction", [[1, 0, 0], [0, -1, 0], [0.3, 0.4, -0.5], [0, 0, -1], [0, 0, 1]])
def test_wxyz_z_to_turns_z_onto_direction(direction):
    w, x, y, z = draw.wxyz_z_to(np.array(direction, float))
    turned = Rotation.from_quat([x, y, z, w]).apply([0, 0, 1])
    np.testing.assert_allclose(turned, np.array(direction) / np.linalg.norm(direction), atol=1e-9)


def test_capsule_mesh_spans_the_segment():
    mesh = draw.capsule_mesh(0.3, 0.02)
    np.testing.assert_allclose(mesh.bounds, [[-0.02, -0.02, -0.02], [0.02, 0.02, 0.32]], atol=1e-9)


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


def test_status_text_names_mode_rate_distance_and_constraints():
    text = status_text("stop", 499.6, 0.2341, ("B joint 2 upper", "B joint 2 upper", "F bar"),
                       np.array([-0.2, 0.03, 0.0]), True)
    assert "**stop**" in text and "500 Hz" in text and "234 mm" in text
    assert "B joint 2 upper, F bar" in text and "stopped" in text and "EE x=-200.0 y=30.0" in text
    assert "contradicting" not in text


def test_status_text_says_why_the_arm_stopped_and_counts_contradicting_retreats():
    text = status_text("anticipative", 1000.0, 0.3, ("human torso",), np.zeros(3), True, ssm=True,
                       reason="yielding: human torso", contradictions=12)
    assert "**stopped** (yielding: human torso)" in text and "contradicting retreats: **12** steps" in text
    moving = status_text("anticipative", 1000.0, 0.3, (), np.zeros(3), False, reason="relaxed", contradictions=0)
    assert "stopped" not in moving and "contradicting" not in moving


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
