"""Laser pipeline on synthetic scans with known legs: filters, detection, torso, scanner pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cobotsafety import LaserScan, detect_legs
from cobotsafety.sensors.laser_filters import TimeFilter, moving_average
from cobotsafety.sensors.legs import LEG_RADIUS_M, estimate_background, torsos_from_legs
from cobotsafety.sensors.scanner_pose import ScannerPose


def render(circles, wall_y=None, beams=271, fov_deg=270.0, max_range=8.0, noise=0.0, seed=0):
    """Ray-cast circles (centre x, y, radius) and an optional wall y = wall_y into a scan."""
    angle_min = -math.radians(fov_deg) / 2
    inc = math.radians(fov_deg) / (beams - 1)
    angles = angle_min + inc * np.arange(beams)
    ranges = np.full(beams, np.inf)
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    for cx, cy, r in circles:
        b = d @ np.array([cx, cy])
        disc = b**2 - (cx**2 + cy**2 - r**2)
        t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
        hit = (disc >= 0) & (t > 0)
        ranges = np.where(hit & (t < ranges), t, ranges)
    if wall_y is not None:
        with np.errstate(divide="ignore"):
            t = wall_y / d[:, 1]
        ranges = np.where((t > 0) & (t < ranges), t, ranges)
    ranges = np.where(ranges > max_range, np.inf, ranges)
    rng = np.random.default_rng(seed)
    ranges = ranges + noise * rng.normal(size=beams)
    return LaserScan(angle_min, inc, 0.05, max_range, ranges)


def test_two_legs_give_two_detections_and_the_torso_between_them():
    legs_true = np.array([[0.9, 0.12], [0.9, -0.12]])
    scan = render([(x, y, LEG_RADIUS_M) for x, y in legs_true], noise=0.003)
    legs = detect_legs(scan, method="paper")  # eq. 3: the centres, one leg radius behind the minima
    assert legs.shape == (2, 2)
    order = np.argsort(legs[:, 1])[::-1]
    np.testing.assert_allclose(legs[order], legs_true, atol=0.03)
    torso = torsos_from_legs(legs)
    assert torso.shape == (1, 2)
    np.testing.assert_allclose(torso[0], [0.9, 0.0], atol=0.03)


def test_one_leg_hidden_gives_one_leg_and_a_torso_at_it():
    scan = render([(0.8, 0.0, LEG_RADIUS_M), (1.1, 0.0, LEG_RADIUS_M)])  # second behind the first
    legs = detect_legs(scan)
    assert legs.shape == (1, 2)
    np.testing.assert_allclose(torsos_from_legs(legs), legs)


def test_a_leg_pairs_with_at_most_one_other():
    """Closest pairs first, each leg in one pair: the two legs 0.1 m apart are one person, the
    leg 0.4 m from one of them (within the pairing distance) stands alone."""
    legs = np.array([[0.5, 0.0], [0.0, 0.0], [0.1, 0.0]])
    torsos = torsos_from_legs(legs)
    np.testing.assert_allclose(torsos[np.argsort(torsos[:, 0])], [[0.05, 0.0], [0.5, 0.0]])


def test_nobody_means_no_leg_and_no_torso():
    for scan in (render([]), render([], wall_y=1.0), render([], wall_y=0.5)):
        legs = detect_legs(scan)
        assert legs.shape == (0, 2)
        assert torsos_from_legs(legs).shape == (0, 2)


def test_no_return_readings_are_never_legs():
    beams = 271
    ranges = np.full(beams, np.inf)
    ranges[100:106] = 0.0  # zeros
    ranges[120:126] = np.nan
    ranges[140:146] = 0.01  # below range_min
    ranges[160:166] = 20.0  # beyond range_max
    ranges[180:186] = -np.inf
    scan = LaserScan(-2.35, 0.0174, 0.05, 8.0, ranges)
    assert detect_legs(scan, max_range_m=30.0).shape == (0, 2)


def test_legs_beyond_the_clipping_range_are_ignored_unless_the_range_is_larger():
    scan = render([(2.0, 0.12, LEG_RADIUS_M), (2.0, -0.12, LEG_RADIUS_M)], beams=811)
    assert detect_legs(scan).shape == (0, 2)  # paper default: 1.4 m
    assert detect_legs(scan, max_range_m=3.0).shape == (2, 2)


def test_background_removes_static_objects():
    post = (0.7, -0.5, 0.06)  # a table leg: leg-sized, static
    empty = render([post])
    assert detect_legs(empty).shape == (1, 2)  # without a background it looks like a leg
    scene = render([post, (1.0, 0.4, LEG_RADIUS_M)])
    legs = detect_legs(scene, background=empty.ranges, method="paper")
    assert legs.shape == (1, 2)
    np.testing.assert_allclose(legs[0], [1.0, 0.4], atol=0.03)
    # People pass through a beam now and then; open space rarely returns.
    background = estimate_background([empty] * 10 + [scene, render([post, (1.2, -0.1, 0.06)])])
    np.testing.assert_allclose(detect_legs(scene, background=background, method="paper"), legs)
    with pytest.raises(ValueError, match="background"):
        detect_legs(scene, background=np.ones(3))


def test_a_person_standing_in_open_space_part_of_the_time_is_not_background():
    """Beams into open space return only while someone stands in them: a person there in 4 of
    10 scans is not the background (docs/leg_recall.md, amendment 2), while a wall those beams
    do not see keeps its range. With the old rule (a surface when returning in over 10 % of the
    scans) the person's own range became the background and hid them."""
    legs = [(2.0, 0.12, LEG_RADIUS_M), (2.0, -0.12, LEG_RADIUS_M)]
    person, empty = render(legs, wall_y=1.5), render([], wall_y=1.5)
    scans = [person] * 4 + [empty] * 6
    background = estimate_background(scans)
    wall = np.isfinite(empty.ranges)
    np.testing.assert_array_equal(background[wall], empty.ranges[wall])
    assert np.isinf(background[~wall]).all()
    assert detect_legs(person, max_range_m=3.0, background=background).shape == (2, 2)
    old_rule = estimate_background(scans, surface_fraction=0.11)
    assert detect_legs(person, max_range_m=3.0, background=old_rule).shape == (0, 2)
    with pytest.raises(ValueError, match="surface_fraction"):
        estimate_background(scans, surface_fraction=0.0)


def test_any_beam_count_and_resolution():
    for beams, fov in ((91, 180.0), (768, 270.0), (1440, 360.0)):
        legs = detect_legs(render([(1.0, 0.2, 0.06), (1.0, -0.05, 0.06)], beams=beams, fov_deg=fov))
        assert legs.shape == (2, 2)


def test_time_filter_is_eq_1_and_moving_average_is_eq_2():
    f = TimeFilter(alpha=0.25)
    np.testing.assert_allclose(f.update(np.array([1.0, 2.0])), [1.0, 2.0])
    np.testing.assert_allclose(f.update(np.array([2.0, 2.0])), [1.25, 2.0])
    np.testing.assert_allclose(f.update(np.array([2.0, 0.0])), [1.4375, 1.5])
    with pytest.raises(ValueError, match="alpha"):
        TimeFilter(alpha=0.0)
    r = np.array([0.0, 3.0, 0.0, 3.0, 6.0])
    np.testing.assert_allclose(moving_average(r, 3), [1.0, 1.0, 2.0, 3.0, 5.0])


def test_scanner_pose_is_eq_10_and_rotates_when_the_scanner_is_turned():
    p = np.array([[1.0, 0.0], [0.0, 2.0]])
    np.testing.assert_allclose(ScannerPose(0.4, -0.4, 0.0).to_base(p), p + [0.4, -0.4])
    np.testing.assert_allclose(ScannerPose(0.4, -0.4, math.pi / 2).to_base(p), [[0.4, 0.6], [-1.6, -0.4]], atol=1e-12)


def test_laser_scan_rejects_bad_fields():
    with pytest.raises(ValueError, match="ranges"):
        LaserScan(0.0, 0.01, 0.0, 5.0, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="angle_increment"):
        LaserScan(0.0, 0.0, 0.0, 5.0, np.ones(10))
    with pytest.raises(ValueError, match="range_min"):
        LaserScan(0.0, 0.01, 5.0, 1.0, np.ones(10))
