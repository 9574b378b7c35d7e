"""The rendered training examples: circles ray-cast exactly, a walk's feet and torso as a gait
has them, ghosts of eq. 1 beside a walking leg."""

from __future__ import annotations

import numpy as np

from cobotsafety.sensors import synthetic_legs as S
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
