"""detect_legs with the learned classifier on synthetic scans: contract, bad inputs, methods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety import LaserScan, detect_legs
from cobotsafety.sensors.leg_clusters import segment
from cobotsafety.sensors.legs import MAX_LEG_WIDTH_M, learned_legs


def render(circles, beams=271, fov_deg=270.0, max_range=8.0, noise=0.0, seed=0, walls=()):
    """Ray-cast circles (x, y, radius) and walls (lines x = a) into a scan."""
    angle_min = -math.radians(fov_deg) / 2
    inc = math.radians(fov_deg) / (beams - 1)
    angles = angle_min + inc * np.arange(beams)
    ranges = np.full(beams, np.inf)
    for cx, cy, r in circles:
        b = np.cos(angles) * cx + np.sin(angles) * cy
        disc = b**2 - (cx**2 + cy**2 - r**2)
        t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
        hit = (disc >= 0) & (t > 0)
        ranges = np.where(hit & (t < ranges), t, ranges)
    for a in walls:
        with np.errstate(divide="ignore"):
            t = a / np.cos(angles)
        ranges = np.where((t > 0) & (t < ranges), t, ranges)
    ranges = np.where(ranges > max_range, np.inf, ranges)
    ranges = ranges + noise * np.random.default_rng(seed).normal(size=beams)
    return LaserScan(angle_min, inc, 0.05, max_range, ranges)


LEGS = np.array([[1.0, 0.13], [1.0, -0.13]])


@pytest.mark.parametrize("beams, fov", [(271, 270.0), (768, 270.0), (512, 180.0), (181, 180.0)])
def test_two_legs_found_at_any_resolution(beams, fov):
    scan = render([(x, y, 0.06) for x, y in LEGS], beams=beams, fov_deg=fov, noise=0.005, walls=(3.0,))
    legs = detect_legs(scan, max_range_m=6.0)
    assert legs.shape == (2, 2)
    legs = legs[np.argsort(-legs[:, 1])]
    np.testing.assert_allclose(legs, LEGS, atol=0.025)  # on the leg axis (eq. 3), within a beam or two


def test_a_wall_alone_is_no_leg():
    for wall in (0.8, 2.0, 4.0):
        assert detect_legs(render([], walls=(wall,), noise=0.003), max_range_m=6.0).shape == (0, 2)


def test_clip_range_applies_to_the_detections():
    scan = render([(2.0, 0.13, 0.06), (2.0, -0.13, 0.06)], beams=811, noise=0.003)
    assert detect_legs(scan).shape == (0, 2)  # default 1.4 m
    assert detect_legs(scan, max_range_m=3.0).shape == (2, 2)


def test_background_removes_a_static_post():
    post = (0.7, -0.5, 0.06)
    empty = render([post])
    scene = render([post, (1.0, 0.4, 0.06)])
    legs = detect_legs(scene, 3.0, background=empty.ranges)
    assert legs.shape == (1, 2)
    assert np.linalg.norm(legs[0] - [1.0, 0.4]) < 0.015
    with pytest.raises(ValueError, match="background"):
        detect_legs(scene, background=np.ones(3))


def test_methods_dispatch():
    scan = render([(x, y, 0.06) for x, y in LEGS])
    np.testing.assert_array_equal(detect_legs(scan, method="learned"), learned_legs(scan))
    paper = detect_legs(scan, method="paper")
    assert paper.shape == (2, 2)  # the paper's rule: centres one leg radius behind the minima
    np.testing.assert_allclose(np.sort(paper[:, 1]), np.sort(LEGS[:, 1]), atol=0.03)
    with pytest.raises(ValueError, match="method"):
        detect_legs(scan, method="magic")


def test_no_return_readings_are_never_legs():
    ranges = np.full(271, np.inf)
    for start, value in ((100, 0.0), (120, np.nan), (140, 0.01), (160, 20.0), (180, -np.inf)):
        ranges[start:start + 8] = value
    scan = LaserScan(-2.35, 0.0174, 0.05, 8.0, ranges)
    assert segment(scan).count == 0
    assert detect_legs(scan, max_range_m=30.0).shape == (0, 2)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from([0.0, np.nan, np.inf, -np.inf, 1e-3, 50.0]), min_size=2, max_size=400),
       st.lists(st.tuples(st.integers(0, 399), st.floats(0.3, 5.0)), max_size=5))
def test_legs_only_come_from_usable_returns(bad, real):
    """Scans of no-returns with a few real readings: every leg lies at a usable return's cluster."""
    ranges = np.array(bad, dtype=float)
    for i, r in real:
        if i < ranges.size:
            ranges[i] = r
    scan = LaserScan(-1.5, 0.01, 0.05, 10.0, ranges)
    legs = detect_legs(scan, max_range_m=10.0)
    assert legs.shape[1] == 2 and np.all(np.isfinite(legs))
    # A cluster needs 3 usable returns; fewer than 3 real readings can never make a leg.
    if np.count_nonzero(scan.valid) < 3:
        assert legs.shape == (0, 2)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.1, 10.0), min_size=3, max_size=60), st.integers(1, 7), st.integers(1, 4))
def test_nearest_averaged_return_kernel_equals_reference(ranges, smoothing_beams, pieces):
    from cobotsafety.sensors.legs import _nearest_averaged_returns, nearest_averaged_returns_reference

    ranges = np.array(ranges)
    cuts = np.linspace(0, ranges.size, pieces + 1).astype(np.int64)
    starts, stops = cuts[:-1], cuts[1:]
    ok = stops > starts
    starts, stops = starts[ok], stops[ok]
    index, value = _nearest_averaged_returns(ranges, starts, stops, smoothing_beams)
    index_ref, value_ref = nearest_averaged_returns_reference(ranges, starts, stops, smoothing_beams)
    np.testing.assert_allclose(value, value_ref, rtol=1e-12, atol=1e-12)
    # Ties between equal windows may pick either index; the averaged value is what matters.
    assert np.all((index >= starts) & (index < stops))


def test_clusters_wider_than_two_legs_are_never_legs():
    """Even a forest that calls everything a leg (threshold below 0) keeps walls out: a cluster
    wider than MAX_LEG_WIDTH_M end to end is not a leg; the two legs in front still are."""
    scan = render([(x, y, 0.06) for x, y in LEGS], beams=811, walls=(2.0,))
    everything = learned_legs(scan, 6.0, threshold_probability=-1.0)
    clusters = segment(scan)
    last = clusters.stops - 1
    width = np.hypot(clusters.x_m[last] - clusters.x_m[clusters.starts], clusters.y_m[last] - clusters.y_m[clusters.starts])
    assert np.any(width > MAX_LEG_WIDTH_M) and everything.shape[0] == np.sum(width <= MAX_LEG_WIDTH_M)
    found = np.linalg.norm(everything[:, None] - LEGS[None], axis=-1).min(axis=0)
    assert np.all(found < 0.03)
    wide = learned_legs(scan, 6.0, threshold_probability=-1.0, max_width_m=np.inf)
    assert wide.shape[0] == clusters.count


def test_background_share_counts_each_cluster_own_returns_only():
    """A cluster in front of the background counts, one on it does not, whatever lies between
    or after them (dropped 2-return clusters, the rest of the scan)."""
    inc = math.radians(0.5)
    # On the background: the 4 m, 3 m and 5 m clusters; in front: the 1 m cluster and the
    # 2-return piece after the 3 m cluster (dropped: too few returns).
    ranges = np.r_[np.full(30, 4.0), np.full(8, 1.0), np.full(3, 3.0), [2.5, 2.5], np.full(30, 5.0)]
    background = np.r_[np.full(30, 4.0), np.full(8, 4.0), np.full(3, 3.0), [4.0, 4.0], np.full(30, 5.0)]
    scan = LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)
    legs = learned_legs(scan, 6.0, background, threshold_probability=-1.0)
    assert legs.shape == (1, 2)
    assert abs(np.hypot(*legs[0]) - (1.0 + 0.06)) < 1e-9  # the 1 m cluster, eq. 3


def test_a_cluster_counts_with_a_cluster_worth_of_returns_in_front_of_the_background():
    """MIN_CLUSTER_POINTS returns in front of the background are enough (a leg half over a spot
    where someone stood still); fewer, and not more than half, are not (edge flicker)."""
    inc = math.radians(0.5)
    wall = np.full(30, 4.0)
    for in_front, expected in ((3, 1), (2, 0)):
        # One 10-return cluster at ~1 m; the empty scene had the 4 m wall behind its first
        # in_front beams and the rest of it (someone standing still) as it is now.
        ranges = np.r_[wall, np.full(in_front, 1.0), np.full(10 - in_front, 1.05), wall]
        background = np.r_[wall, np.full(in_front, 4.0), np.full(10 - in_front, 1.05), wall]
        scan = LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)
        assert segment(scan).count == 3
        legs = learned_legs(scan, 6.0, background, threshold_probability=-1.0)
        assert legs.shape == (expected, 2)
