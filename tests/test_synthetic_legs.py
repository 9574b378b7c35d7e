"""The rendered training examples: circles ray-cast exactly, a walk's feet and torso as a gait
has them, ghosts of eq. 1 beside a walking leg."""

from __future__ import annotations

import numpy as np

from cobotsafety.tools import synthetic_legs as S
from cobotsafety.sensors.leg_clusters import segment


def test_a_rendered_circle_reads_its_exact_distance():
    """Without noise, the beam through the centre reads distance - radius; a beam that misses
    reads no return; the clusters' centroid lies just in front of the centre."""
    centre, radius = np.array([1.2, 0.4]), 0.07
    scan = S.render_circles(np.array([[*centre, radius]]), 0.0, np.random.default_rng(0))
    bearing = np.arctan2(centre[1], centre[0])
    beam = int(np.argmin(np.abs(scan.angles - bearing)))
    off = scan.angles[beam] - bearing  # the law of cosines along that beam
    d = np.linalg.norm(centre)
    expected = d * np.cos(off) - np.sqrt(radius ** 2 - (d * np.sin(off)) ** 2)
    assert abs(scan.ranges[beam] - expected) < 1e-12
    assert scan.ranges[0] == 0.0 and not scan.valid[0]
    clusters = segment(scan)
    assert clusters.count == 1
    assert 0.0 < np.linalg.norm(centre) - np.linalg.norm(clusters.centroids()[0]) < radius


def test_a_walk_has_one_foot_standing_and_the_torso_moving_steadily():
    t = np.arange(0.0, 3.0, 0.01)
    legs = S.walking_legs(t, np.array([1.0, 0.0]), 0.5, 0.8, 0.1)
    heading = np.array([np.cos(0.5), np.sin(0.5)])
    torso = legs.mean(axis=1)
    np.testing.assert_allclose(torso, np.array([1.0, 0.0]) + 0.8 * t[:, None] * heading, atol=1e-12)
    speeds = np.linalg.norm(np.diff(legs, axis=0), axis=2) / 0.01  # (n-1, 2)
    # One foot stands while the other swings at twice the walk (an interval holding a change
    # of step has both move a part of it; the feet never go backwards).
    np.testing.assert_allclose(speeds.sum(axis=1), 1.6, atol=1e-9)
    assert np.mean(speeds.min(axis=1) < 1e-9) > 0.9
    np.testing.assert_allclose(np.linalg.norm(legs[:, 0] - legs[:, 1], axis=1).min(), 0.2, atol=0.01)


def test_walks_give_legs_and_ghosts_the_same_every_run():
    x, y = S.walking_examples(walks=3)
    x2, y2 = S.walking_examples(walks=3)
    np.testing.assert_array_equal(x, x2)
    np.testing.assert_array_equal(y, y2)
    assert y.sum() > 0 and (y == 0).sum() > 0


def test_a_wall_behind_the_legs_gives_non_leg_pieces():
    """A straight wall 1 m behind two legs: its straight pieces (the wall seen between and
    beside the legs' shadows) are non-leg examples, the two leg arcs legs; the wall's points
    lie on its line."""
    legs = np.array([[2.0, 0.15], [2.0, -0.15]])
    circles = np.column_stack([legs, [0.06, 0.06]])
    scan = S.render_circles(circles, 0.0, np.random.default_rng(0), wall=(0.0, 3.0))  # the line x = 3 m
    features, leg = S.scene_examples(scan, legs)
    assert leg.sum() == 2 and (leg == 0).sum() >= 2
    points = scan.ranges[scan.valid][:, None] * np.column_stack([np.cos(scan.angles[scan.valid]),
                                                                  np.sin(scan.angles[scan.valid])])
    on_wall = np.abs(points[:, 0] - 3.0) < 1e-9
    near_legs = np.linalg.norm(points[:, None] - legs[None], axis=-1).min(axis=1) < 0.061
    assert np.all(on_wall | near_legs)
    assert np.all(np.linalg.norm(points[on_wall], axis=1) <= S.RANGE_MAX_M + 1e-9)
