"""Split a laser scan into clusters of neighbouring returns (jump-distance segmentation).

Consecutive usable returns (in beam order; no-return beams are skipped) belong to one cluster
while the Euclidean gap between them stays below ``jump_m`` (0.13 m, the clustering of the
hand-labelled leg_tracker bags: their labels are the centroids of exactly these clusters).
Clusters of fewer than ``min_points`` returns are dropped (too few points to say anything).

Every usable return up to the scanner's own range is clustered: a range clip applies to the
detections afterwards, so a wall that crosses the clip range stays a wall, not a leg-sized
stub.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cobotsafety.sensors.laser_scan import LaserScan

#: Largest gap [m] between two consecutive returns of one cluster.
CLUSTER_JUMP_M = 0.13
#: Fewest returns a cluster needs.
MIN_CLUSTER_POINTS = 3


class Clusters(NamedTuple):
    """The clusters of one scan.

    ``beams`` (m,): indices of the usable beams, in scan order; ``x_m``, ``y_m``, ``ranges_m``
    (m,): their points [m] in the scanner frame and ranges [m]; cluster j is
    ``beams[starts[j]:stops[j]]`` (``starts``, ``stops``: (c,) int64, half-open).
    """

    beams: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    ranges_m: np.ndarray
    starts: np.ndarray
    stops: np.ndarray

    @property
    def count(self) -> int:
        return int(self.starts.size)

    def centroids(self) -> np.ndarray:
        """Shape (c, 2) [m], the mean point of each cluster.

        Sums over ``starts:stops`` from cumulative sums: the returns of dropped (too short)
        clusters lie between the kept ones and must not count (``np.add.reduceat`` over the
        starts alone would add them to the cluster before).
        """
        n = self.stops - self.starts
        sums = []
        for coordinate in (self.x_m, self.y_m):
            cumulative = np.concatenate([[0.0], np.cumsum(coordinate)])
            sums.append(cumulative[self.stops] - cumulative[self.starts])
        return np.column_stack([sums[0] / n, sums[1] / n]).reshape(-1, 2)

    def widths(self) -> np.ndarray:
        """Shape (c,) [m], each cluster's width: the distance from its first to its last return."""
        last = self.stops - 1
        return np.hypot(self.x_m[last] - self.x_m[self.starts], self.y_m[last] - self.y_m[self.starts])


def segment(scan: LaserScan, jump_m: float = CLUSTER_JUMP_M,
            min_points: int = MIN_CLUSTER_POINTS) -> Clusters:
    """The clusters of ``scan`` (any beam count and resolution)."""
    beams = np.flatnonzero(scan.valid)
    ranges = scan.ranges[beams]
    angles = scan.angle_min + scan.angle_increment * beams
    x, y = ranges * np.cos(angles), ranges * np.sin(angles)
    if beams.size == 0:
        empty = np.zeros(0, dtype=np.int64)
        return Clusters(beams, x, y, ranges, empty, empty)
    gap = np.hypot(np.diff(x), np.diff(y)) >= jump_m
    starts = np.concatenate([[0], np.flatnonzero(gap) + 1]).astype(np.int64)
    stops = np.concatenate([np.flatnonzero(gap) + 1, [beams.size]]).astype(np.int64)
    keep = stops - starts >= min_points
    return Clusters(beams, x, y, ranges, starts[keep], stops[keep])
