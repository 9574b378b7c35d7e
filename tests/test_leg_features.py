"""Cluster segmentation and cluster features: the compiled kernel against the numpy reference,
and the geometry of circles and lines against their known shapes."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.leg_clusters import CLUSTER_JUMP_M, segment
from cobotsafety.sensors.leg_context import CONTEXT_CAP_M
from cobotsafety.sensors.leg_features import (FEATURE_NAMES, JUMP_CAP_M, RADIUS_CAP_M, cluster_features,
                                               features_reference)
from cobotsafety.sensors.rosbag_io import read_laser_scans

F = {name: i for i, name in enumerate(FEATURE_NAMES)}


def scan_of(ranges, inc=math.radians(0.5)) -> LaserScan:
    ranges = np.asarray(ranges, dtype=float)
    return LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)


def circle_scan(cx, cy, radius, beams=721, inc=math.radians(0.25)) -> LaserScan:
    """Ray-cast one circle (exact ranges), nothing else in view."""
    angles = -inc * (beams - 1) / 2 + inc * np.arange(beams)
    b = np.cos(angles) * cx + np.sin(angles) * cy
    disc = b**2 - (cx**2 + cy**2 - radius**2)
    ranges = np.where(disc >= 0, b - np.sqrt(np.abs(disc)), np.inf)
    return LaserScan(angles[0], inc, 0.02, 20.0, ranges)


def test_segmentation_splits_at_jumps_and_skips_no_returns():
    ranges = np.r_[np.full(10, 2.0), np.full(10, 2.5), [np.nan, 0.0, np.inf, -np.inf], np.full(10, 2.5), [2.0, 2.0]]
    clusters = segment(scan_of(ranges))
    assert clusters.count == 2  # 10 at 2 m; 20 at 2.5 m across the 4 no-returns (11 cm apart); the last 2: too few
    assert np.all(np.isfinite(clusters.ranges_m)) and np.all(clusters.ranges_m > 0)
    np.testing.assert_array_equal(clusters.stops - clusters.starts, [10, 20])
    cx = clusters.centroids()
    assert abs(np.hypot(*cx[0]) - 2.0) < 0.01


def split_reference(x, y, jump_m, min_points):
    """The oracle of ``segment``'s compiled split: numpy over the gaps between consecutive points."""
    gap = np.hypot(np.diff(x), np.diff(y)) >= jump_m
    starts = np.concatenate([[0], np.flatnonzero(gap) + 1]).astype(np.int64)
    stops = np.concatenate([np.flatnonzero(gap) + 1, [x.size]]).astype(np.int64)
    keep = stops - starts >= min_points
    return starts[keep], stops[keep]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(st.floats(0.05, 8.0), st.sampled_from([0.0, np.nan, np.inf])), min_size=2, max_size=300),
       st.floats(0.001, 0.05), st.floats(0.01, 1.0), st.integers(1, 5))
def test_split_equals_the_numpy_reference(ranges, inc, jump_m, min_points):
    clusters = segment(scan_of(ranges, inc), jump_m, min_points)
    starts, stops = split_reference(clusters.x_m, clusters.y_m, jump_m, min_points) if clusters.x_m.size else ([], [])
    np.testing.assert_array_equal(clusters.starts, starts)
    np.testing.assert_array_equal(clusters.stops, stops)
    assert clusters.starts.dtype == clusters.stops.dtype == np.int64


def centroids_by_loop(clusters):
    """The oracle: each cluster's own returns, averaged one cluster at a time."""
    return np.array([[clusters.x_m[a:b].mean(), clusters.y_m[a:b].mean()]
                     for a, b in zip(clusters.starts.tolist(), clusters.stops.tolist())]).reshape(-1, 2)


def test_centroids_leave_out_the_dropped_clusters_between():
    """A 2-return piece (dropped: too few) between two clusters is no part of either centroid."""
    ranges = np.r_[np.full(10, 2.0), [1.0, 1.0], np.full(10, 3.0), [0.5, 0.5]]
    clusters = segment(scan_of(ranges))
    assert clusters.count == 2
    np.testing.assert_allclose(clusters.centroids(), centroids_by_loop(clusters), rtol=0, atol=1e-12)
    assert abs(np.hypot(*clusters.centroids()[0]) - 2.0) < 0.01


@settings(max_examples=100, deadline=None)
@given(st.lists(st.one_of(st.floats(0.05, 8.0), st.sampled_from([0.0, np.nan, np.inf])), min_size=2, max_size=300),
       st.floats(0.001, 0.05))
def test_centroids_equal_a_loop_over_clusters(ranges, inc):
    clusters = segment(scan_of(ranges, inc))
    np.testing.assert_allclose(clusters.centroids(), centroids_by_loop(clusters), rtol=0, atol=1e-9)


def test_centroids_on_real_scans_equal_a_loop_over_clusters(shared_data):
    bag = shared_data / "leg_tracker" / "positive_2_extracted.bag"
    for scan in read_laser_scans(bag, "/training_scan"):
        clusters = segment(scan)
        np.testing.assert_allclose(clusters.centroids(), centroids_by_loop(clusters), rtol=0, atol=1e-9)


def test_a_gap_wider_than_the_jump_splits_a_wall():
    inc = math.radians(0.5)
    ranges = np.full(200, 1.0)
    ranges[100:100 + math.ceil(CLUSTER_JUMP_M / inc) + 1] = np.nan  # gap along the arc > jump
    assert segment(scan_of(ranges, inc)).count == 2


def test_circle_features_match_the_circle():
    radius = 0.06
    scan = circle_scan(1.5, 0.3, radius)
    clusters = segment(scan)
    assert clusters.count == 1
    f = cluster_features(scan, clusters)[0]
    assert abs(f[F["radius_m"]] - radius) < 1e-6
    assert f[F["circularity_m"]] < 1e-9
    assert f[F["linearity_m"]] > 1e-3
    # Centre behind the visible arc, by about half a radius (centroid of a half circle).
    assert 0.3 * radius < f[F["convexity_m"]] < radius
    assert abs(f[F["mean_curvature_1_m"]] - 1 / radius) < 1e-6 * (1 / radius)
    assert f[F["inscribed_angle_std_rad"]] < 1e-9  # constant along an arc
    assert f[F["jump_before_m"]] == f[F["jump_after_m"]] == JUMP_CAP_M  # open space around it
    assert abs(f[F["range_m"]] - (math.hypot(1.5, 0.3) - 0.5 * radius)) < 0.02


def test_wall_features_are_straight():
    inc = math.radians(0.5)
    angles = -inc * 99.5 + inc * np.arange(200)
    scan = scan_of(1.0 / np.cos(angles), inc)  # the wall x = 1 m
    f = cluster_features(scan, segment(scan))[0]
    assert f[F["linearity_m"]] < 1e-9
    assert f[F["radius_m"]] == RADIUS_CAP_M
    assert f[F["mean_curvature_1_m"]] < 1e-6
    assert abs(f[F["width_m"]] - 2 * math.tan(inc * 99.5)) < 1e-9


def test_kernel_equals_reference_on_real_scans(shared_data):
    bag = shared_data / "leg_tracker" / "positive_1_extracted.bag"
    for scan in read_laser_scans(bag, "/training_scan")[::10]:
        clusters = segment(scan)
        np.testing.assert_allclose(cluster_features(scan, clusters), features_reference(scan, clusters),
                                   rtol=1e-9, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.floats(0.05, 8.0), st.sampled_from([0.0, np.nan, np.inf])), min_size=2, max_size=300),
       st.floats(0.001, 0.05))
def test_kernel_equals_reference_on_random_scans(ranges, inc):
    scan = scan_of(ranges, inc)
    clusters = segment(scan)
    fast, slow = cluster_features(scan, clusters), features_reference(scan, clusters)
    assert fast.shape == slow.shape == (clusters.count, len(FEATURE_NAMES))
    assert np.all(np.isfinite(fast))
    # Near-collinear triples make the circle fit ill-conditioned: compare relative to scale.
    np.testing.assert_allclose(fast, slow, rtol=1e-7, atol=1e-7)


def two_circles_scan(c1, c2, radius=0.06, beams=1441, inc=math.radians(0.125)) -> LaserScan:
    """Ray-cast two circles (the nearer hit per beam), nothing else in view."""
    angles = -inc * (beams - 1) / 2 + inc * np.arange(beams)
    hits = []
    for cx, cy in (c1, c2):
        b = np.cos(angles) * cx + np.sin(angles) * cy
        disc = b**2 - (cx**2 + cy**2 - radius**2)
        hits.append(np.where(disc >= 0, b - np.sqrt(np.abs(disc)), np.inf))
    return LaserScan(angles[0], inc, 0.02, 20.0, np.minimum(*hits))


def test_context_of_two_legs_in_open_space():
    """Two legs 0.3 m apart: each one's nearest other cluster is the other leg, at the distance of
    their centroids (computed here from the other cluster's own points), its width the other's;
    the nearest foreign return is the other leg's nearest point; nothing within 0.5 m but it."""
    scan = two_circles_scan((2.0, 0.15), (2.0, -0.15))
    clusters = segment(scan)
    assert clusters.count == 2
    f = cluster_features(scan, clusters)
    c = centroids_by_loop(clusters)
    pts = [np.column_stack([clusters.x_m[a:b], clusters.y_m[a:b]]) for a, b in zip(clusters.starts, clusters.stops)]
    for j, k in ((0, 1), (1, 0)):
        assert abs(f[j, F["nearest_cluster_m"]] - np.linalg.norm(c[j] - c[k])) < 1e-12
        assert abs(f[j, F["nearest_cluster_width_m"]] - f[k, F["width_m"]]) < 1e-12
        assert abs(f[j, F["nearest_return_m"]] - np.linalg.norm(pts[k] - c[j], axis=1).min()) < 1e-12
        assert f[j, F["returns_within_0_5_m"]] == f[j, F["returns_within_1_m"]] == len(pts[k])
    alone = circle_scan(1.5, 0.3, 0.06)
    g = cluster_features(alone, segment(alone))[0]
    assert g[F["nearest_cluster_m"]] == g[F["nearest_return_m"]] == CONTEXT_CAP_M
    assert g[F["nearest_cluster_width_m"]] == g[F["returns_within_1_m"]] == 0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.one_of(st.floats(0.05, 8.0), st.sampled_from([0.0, np.nan, np.inf])), min_size=2, max_size=300),
       st.floats(0.001, 0.05), st.integers(0, 2**32 - 1))
def test_features_of_some_rows_are_those_rows_of_all(ranges, inc, seed):
    """``rows`` picks clusters; their context is still among all clusters of the scan."""
    scan = scan_of(ranges, inc)
    clusters = segment(scan)
    rows = np.flatnonzero(np.random.default_rng(seed).random(clusters.count) < 0.5)
    every = cluster_features(scan, clusters)
    np.testing.assert_array_equal(cluster_features(scan, clusters, rows), every[rows])
    np.testing.assert_allclose(features_reference(scan, clusters, rows), every[rows], rtol=1e-7, atol=1e-7)
