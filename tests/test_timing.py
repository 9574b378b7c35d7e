"""Stream time alignment (interpolation, slerp, stale) and the conservative human model."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from cobotsafety.human.body import CAPSULE_NAMES_1, CAPSULE_NAMES_5, BodyDimensions
from cobotsafety.human.conservative import StalePolicy, conservative_capsules, could_have_left
from cobotsafety.sensors.streams import QuaternionStream, VectorStream

BODY = BodyDimensions()
POLICY = StalePolicy(laser_stale_after_s=0.1, imu_stale_after_s=0.05, speed_m_s=1.6)


def torso_stream():
    s = VectorStream("torso", 2, stale_after_s=0.1)
    assert s.push(0.00, [1.0, 0.0])
    assert s.push(0.02, [1.2, -0.4])
    assert s.push(0.04, [1.2, -0.4])
    return s


def test_linear_interpolation_and_hold():
    s = torso_stream()
    assert np.allclose(s.value_at(0.005), [1.05, -0.1])
    assert np.allclose(s.value_at(0.02), [1.2, -0.4])
    assert np.allclose(s.value_at(-1.0), [1.0, 0.0])  # before the first sample: the first
    assert np.allclose(s.value_at(9.0), [1.2, -0.4])  # after the newest: held


def test_until_hides_future_samples():
    s = torso_stream()
    assert np.allclose(s.value_at(0.015, until_s=0.01), [1.0, 0.0])  # causal: only t <= 0.01
    assert s.newest_s(until_s=0.03) == 0.02
    assert s.age_s(0.03, until_s=0.03) == pytest.approx(0.01)
    with pytest.raises(LookupError, match="torso"):
        s.value_at(0.0, until_s=-0.5)


def test_stale_threshold():
    s = torso_stream()
    assert not s.is_stale(0.14)
    assert s.is_stale(0.1401)
    empty = VectorStream("x", 1, stale_after_s=0.1)
    assert empty.is_stale(0.0) and empty.age_s(0.0) == np.inf


def test_push_refuses_garbage_and_keeps_stream():
    s = torso_stream()
    assert not s.push(0.06, [np.nan, 0.0])
    assert "non-finite" in s.last_rejection and s.last_rejection.startswith("torso")
    assert not s.push(0.03, [0.0, 0.0])
    assert "not after" in s.last_rejection
    assert not s.push(0.06, [0.0, 0.0, 0.0])
    assert s.rejected == 3 and len(s) == 3 and s.newest_s() == 0.04
    q = QuaternionStream("chest", stale_after_s=0.05)
    assert not q.push(0.0, [0.0, 0.0, 0.0, 1.1])
    assert "norm" in q.last_rejection
    assert q.push(0.0, [0.0, 0.0, 0.0, 1.0005])
    assert np.linalg.norm(q.value_at(0.0)) == pytest.approx(1.0)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_slerp_matches_scipy(seed, frac):
    r = Rotation.random(2, random_state=seed)
    q = QuaternionStream("imu", stale_after_s=0.05)
    q.push(1.0, r[0].as_quat())
    q.push(1.004, (-r[1].as_quat()))  # the other sign of the same rotation: shortest arc anyway
    expected = Slerp([1.0, 1.004], r)([1.0 + 0.004 * frac])[0]
    got = q.rotation_at(1.0 + 0.004 * frac)
    assert (got.inv() * expected).magnitude() < 1e-7


def test_slerp_quarter_of_a_right_angle():
    q = QuaternionStream.from_arrays("imu", [0.0, 1.0], Rotation.from_euler("z", [[0], [90]], degrees=True).as_quat(), 2.0)
    assert np.allclose(q.rotation_at(0.25).as_euler("xyz", degrees=True), [0, 0, 22.5])


def test_from_arrays_refuses_unsorted_time():
    with pytest.raises(ValueError, match="imu"):
        QuaternionStream.from_arrays("imu", [0.0, 0.0], np.tile([0, 0, 0, 1.0], (2, 1)), 0.05)


ROTATIONS = Rotation.from_matrix(np.tile(np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float), (5, 1, 1)))
FRESH_IMUS = {name: 0.003 for name in CAPSULE_NAMES_5}


def test_fresh_model_is_five_capsules_with_latency_margin():
    caps = conservative_capsules(0.0, [1.0, 0.0], 0.02, BODY, ROTATIONS, FRESH_IMUS, POLICY)
    assert caps.names == CAPSULE_NAMES_5 and not caps.stale and caps.reason == ""
    assert caps.radius_m[0] == pytest.approx(BODY.torso_radius_m + 1.6 * 0.02)


def test_stale_laser_holds_pose_and_grows():
    caps = conservative_capsules(0.0, [1.0, 0.0], 0.5, BODY, ROTATIONS, FRESH_IMUS, POLICY)
    assert caps.stale and "laser" in caps.reason
    assert caps.radius_m[1] == pytest.approx(BODY.upper_arm_radius_m + 0.8)


def test_silent_imu_gives_one_big_capsule():
    ages = dict(FRESH_IMUS, forearm_left=0.3)
    caps = conservative_capsules(0.0, [1.0, 0.0], 0.0, BODY, ROTATIONS, ages, POLICY)
    assert caps.names == CAPSULE_NAMES_1 and caps.stale and "forearm_left" in caps.reason
    assert caps.radius_m[0] == pytest.approx(BODY.one_capsule_radius_m)


def test_laser_only_is_one_capsule_not_stale():
    caps = conservative_capsules(0.0, [1.0, 0.0], 0.0, BODY, policy=POLICY)
    assert caps.names == CAPSULE_NAMES_1 and not caps.stale


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 5), st.floats(0, 5), st.floats(0, 0.3))
def test_never_shrinks_while_silent(age_a, extra, imu_age):
    ages = dict(FRESH_IMUS, chest=imu_age)
    a = conservative_capsules(0.0, [1.0, 0.0], age_a, BODY, ROTATIONS, ages, POLICY)
    b = conservative_capsules(0.0, [1.0, 0.0], age_a + extra, BODY, ROTATIONS, dict(ages, chest=imu_age + extra), POLICY)
    # b's capsules contain a's: same axes (or the 1-capsule, which contains the 5) and radii >= a's
    if a.names == b.names:
        assert np.all(b.radius_m >= a.radius_m - 1e-12)
    else:
        assert b.names == CAPSULE_NAMES_1 and b.radius_m[0] >= a.radius_m.max()


def test_could_have_left():
    assert could_have_left(1.3, 0.07, 1.4, POLICY)
    assert not could_have_left(0.6, 0.2, 1.4, POLICY)


def test_bad_age_is_refused():
    with pytest.raises(ValueError, match="torso_age_s"):
        conservative_capsules(0.0, [1.0, 0.0], float("nan"), BODY, policy=POLICY)


def test_no_interpolation_across_a_gap():
    s = VectorStream.from_arrays("torso", [0.0, 1.0], [[0.0, 0.0], [1.0, 1.0]], stale_after_s=0.1)
    assert np.allclose(s.value_at(0.5), [0.0, 0.0])
