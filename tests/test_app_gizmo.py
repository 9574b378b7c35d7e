"""Gizmo offset -> velocity: dead band, gain, cap, NaN (hand-worked numbers and invariants)."""

import numpy as np
import pytest
from hypothesis import given, strategies as st

from cobotsafety.app.gizmo import GizmoSettings, GizmoSettingsError, offset_to_velocity

SETTINGS = GizmoSettings(dead_band_m=0.01, gain_per_s=2.0, max_speed_m_s=0.25)


def test_inside_dead_band_is_zero():
    assert np.array_equal(offset_to_velocity(np.array([0.006, 0.008, 0.0]), SETTINGS), np.zeros(3))


def test_linear_beyond_dead_band_hand_worked():
    # |offset| = 0.05 m along x: 2 * (0.05 - 0.01) = 0.08 m/s along x.
    np.testing.assert_allclose(offset_to_velocity(np.array([0.05, 0.0]), SETTINGS), [0.08, 0.0])
    # 3-4-5 triangle: |offset| = 0.10 m, speed 0.18 m/s, direction (0.6, 0.8).
    np.testing.assert_allclose(offset_to_velocity(np.array([0.06, 0.08, 0.0]), SETTINGS), [0.108, 0.144, 0.0])


def test_speed_is_capped():
    np.testing.assert_allclose(offset_to_velocity(np.array([0.0, -3.0, 0.0]), SETTINGS), [0.0, -0.25, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_offset_gives_zero(bad):
    assert np.array_equal(offset_to_velocity(np.array([0.1, bad, 0.0]), SETTINGS), np.zeros(3))


def test_negative_setting_is_refused_by_name():
    with pytest.raises(GizmoSettingsError, match="gain_per_s"):
        GizmoSettings(gain_per_s=-1.0)


finite = st.floats(-10, 10, allow_nan=False)


@given(st.lists(finite, min_size=3, max_size=3))
def test_velocity_points_along_offset_and_respects_cap(offset):
    offset = np.array(offset)
    v = offset_to_velocity(offset, SETTINGS)
    assert np.linalg.norm(v) <= SETTINGS.max_speed_m_s + 1e-12
    assert np.linalg.norm(np.cross(v, offset)) <= 1e-9
    assert v @ offset >= 0.0
