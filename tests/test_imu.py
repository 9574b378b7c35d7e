"""IMU chain (paper 2, eqs. 5-12, erratum 7) on hand-worked poses, and the capsule models."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from cobotsafety.human.body import CAPSULE_NAMES_5, BodyDimensions
from cobotsafety.human.body_capsules import five_capsules, one_capsule
from cobotsafety.sensors.imu import arm_chain, base_orientation, calibrate

BODY = BodyDimensions(d1_m=0.2, d2_m=0.2, d3_m=0.3, d4_m=0.28, chest_height_m=0.6)
XY = np.array([1.0, 0.0])
P0 = np.array([1.0, 0.0, 0.6])


def frame(x_axis, z_axis) -> Rotation:
    """IMU orientation in the base frame from where its x and z axes point."""
    x, z = np.asarray(x_axis, float), np.asarray(z_axis, float)
    return Rotation.from_matrix(np.column_stack([x, np.cross(z, x), z]))


# Human facing +x (left is +y). Chest IMU: x down, z forward (out of the chest).
CHEST = frame([0, 0, -1], [1, 0, 0])
DOWN = frame([0, 0, -1], [1, 0, 0])
LEFT = frame([0, 1, 0], [1, 0, 0])
RIGHT = frame([0, -1, 0], [1, 0, 0])
FORWARD = frame([1, 0, 0], [0, 0, 1])


def chain(*rotations):
    return arm_chain(P0, Rotation.concatenate(rotations), BODY.d1_m, BODY.d2_m, BODY.d3_m, BODY.d4_m)


def test_chest_frame_y_points_left():
    assert np.allclose(CHEST.apply([0, 1, 0]), [0, 1, 0])


def test_arms_down():
    arm = chain(CHEST, DOWN, DOWN, DOWN, DOWN)
    assert np.allclose(arm.shoulder_left, [1.0, 0.2, 0.8])
    assert np.allclose(arm.shoulder_right, [1.0, -0.2, 0.8])  # erratum 7: -d2 on the right
    assert np.allclose(arm.elbow_left, [1.0, 0.2, 0.5])
    assert np.allclose(arm.wrist_left, [1.0, 0.2, 0.22])
    assert np.allclose(arm.elbow_right, [1.0, -0.2, 0.5])
    assert np.allclose(arm.wrist_right, [1.0, -0.2, 0.22])


def test_t_pose():
    arm = chain(CHEST, LEFT, LEFT, RIGHT, RIGHT)
    assert np.allclose(arm.elbow_left, [1.0, 0.5, 0.8])
    assert np.allclose(arm.wrist_left, [1.0, 0.78, 0.8])
    assert np.allclose(arm.elbow_right, [1.0, -0.5, 0.8])
    assert np.allclose(arm.wrist_right, [1.0, -0.78, 0.8])


def test_right_arm_forward_left_down():
    arm = chain(CHEST, DOWN, DOWN, FORWARD, FORWARD)
    assert np.allclose(arm.elbow_right, [1.3, -0.2, 0.8])
    assert np.allclose(arm.wrist_right, [1.58, -0.2, 0.8])
    assert np.allclose(arm.wrist_left, [1.0, 0.2, 0.22])


def test_chest_turned_to_face_plus_y_moves_shoulders():
    chest = frame([0, 0, -1], [0, 1, 0])  # facing +y: left is -x
    arm = chain(chest, DOWN, DOWN, DOWN, DOWN)
    assert np.allclose(arm.shoulder_left, [0.8, 0.0, 0.8])
    assert np.allclose(arm.shoulder_right, [1.2, 0.0, 0.8])


def hamilton(q, r):
    """Quaternion product, scalar-last, written out (independent of scipy)."""
    x1, y1, z1, w1 = q
    x2, y2, z2, w2 = r
    return np.array([
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    ])


quaternions = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(
    lambda q: np.linalg.norm(q) > 0.1).map(lambda q: np.array(q) / np.linalg.norm(q))


@settings(max_examples=60, deadline=None)
@given(quaternions, quaternions, quaternions, quaternions)
def test_calibration_recovers_base_orientation(q_ref_b, q_b_init, q_b_later, q_drift_free):
    """Eq. 5-7 against the quaternion sandwich product computed by hand."""
    r_ref_b = Rotation.from_quat(q_ref_b)  # the IMU's unknown reference frame
    reading_init = (r_ref_b * Rotation.from_quat(q_b_init)).as_quat()
    reading_later = (r_ref_b * Rotation.from_quat(q_b_later)).as_quat()
    r_b_ref = calibrate(reading_init, q_b_init)
    q_b_imu = base_orientation(r_b_ref, reading_later).as_quat()
    assert min(np.linalg.norm(q_b_imu - q_b_later), np.linalg.norm(q_b_imu + q_b_later)) < 1e-9
    v = np.array([0.3, 0.0, 0.0])
    conj = q_b_imu * np.array([-1, -1, -1, 1])
    sandwich = hamilton(hamilton(q_b_imu, np.append(v, 0.0)), conj)  # eq. 7
    assert np.allclose(sandwich[:3], Rotation.from_quat(q_b_later).apply(v), atol=1e-9)


def test_calibration_is_per_imu_batched():
    rng = np.random.default_rng(1)
    r_ref_b = Rotation.random(5, random_state=rng)
    known = Rotation.random(5, random_state=rng)
    r_b_ref = calibrate((r_ref_b * known).as_quat(), known.as_quat())
    assert np.allclose((r_b_ref * r_ref_b).magnitude(), 0.0, atol=1e-9)


def test_five_capsules_layout_and_radii():
    caps = five_capsules(XY, Rotation.concatenate([CHEST, DOWN, DOWN, FORWARD, FORWARD]), BODY)
    assert caps.names == CAPSULE_NAMES_5
    p0, p1, r = caps.by_name("torso")
    assert np.allclose(p0, [1.0, 0.0, 0.05]) and np.allclose(p1, [1.0, 0.0, 0.85])
    assert r == BODY.torso_radius_m
    p0, p1, r = caps.by_name("forearm_right")
    assert np.allclose(p0, [1.3, -0.2, 0.8]) and np.allclose(p1, [1.58, -0.2, 0.8])
    assert r == BODY.forearm_radius_m


def point_segment_distance(p, a, b):
    ab = b - a
    s = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + s * ab))


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-180, 180))
def test_one_capsule_contains_every_arm_pose(seed, heading_deg):
    """Each 5-capsule end-point ball lies inside the 1-capsule (capsules are convex)."""
    chest = Rotation.from_euler("z", heading_deg, degrees=True) * CHEST
    arms = Rotation.random(4, random_state=seed)
    caps = five_capsules(XY, Rotation.concatenate([chest, arms]), BODY)
    big = one_capsule(XY, BODY)
    a, b, radius = big.by_name("body")
    for p0, p1, r in zip(caps.p0_b_m, caps.p1_b_m, caps.radius_m):
        for p in (p0, p1):
            assert point_segment_distance(p, a, b) + r <= radius + 1e-9


@settings(max_examples=120, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-180, 180), st.floats(0.0, 0.3), st.floats(0.0, 0.3), st.floats(0.0, 0.4),
       st.floats(0.0, 0.4), st.floats(0.0, 0.5), st.floats(0.1, 0.25), st.floats(0.02, 0.1))
def test_one_capsule_contains_every_arm_pose_of_any_body(seed, heading_deg, d1, d2, d3, d4, head, torso_r, arm_r):
    """The same for bodies other than the default (short arms and a tall head, say): the one
    capsule holds the head's top too, not only the arms."""
    body = BodyDimensions(d1_m=d1, d2_m=d2, d3_m=d3, d4_m=d4, head_above_chest_m=head, torso_radius_m=torso_r,
                          upper_arm_radius_m=arm_r, forearm_radius_m=arm_r)
    chest = Rotation.from_euler("z", heading_deg, degrees=True) * CHEST
    caps = five_capsules(XY, Rotation.concatenate([chest, Rotation.random(4, random_state=seed)]), body)
    a, b, radius = one_capsule(XY, body).by_name("body")
    for p0, p1, r in zip(caps.p0_b_m, caps.p1_b_m, caps.radius_m):
        for p in (p0, p1):
            assert point_segment_distance(p, a, b) + r <= radius + 1e-9


def test_arm_chain_wants_five_rotations():
    with pytest.raises(ValueError, match="r_b_imu"):
        arm_chain(P0, Rotation.concatenate([CHEST, DOWN]), 0.2, 0.2, 0.3, 0.28)


def test_body_dimensions_refuse_nan_and_negative():
    with pytest.raises(ValueError, match="d3_m"):
        BodyDimensions(d3_m=float("nan"))
    with pytest.raises(ValueError, match="torso_radius_m"):
        BodyDimensions(torso_radius_m=-0.1)
