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

import numba
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
        """Shape (c, 2) [m], the mean point of each cluster (its own returns only: the returns
        of dropped, too short clusters lie between the kept ones and do not count)."""
        return _centroids(self.x_m, self.y_m, self.starts, self.stops)

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
    starts, stops = _split(x, y, float(jump_m), int(min_points))
    return Clusters(beams, x, y, ranges, starts, stops)


@numba.njit(cache=True)
def _split(x, y, jump_m, min_points):  # pragma: no cover - compiled
    """Half-open (starts, stops) of the runs of consecutive points (m,) closer than ``jump_m``
    to their predecessor, runs shorter than ``min_points`` dropped."""
    m = x.size
    starts = np.empty(m, dtype=np.int64)
    stops = np.empty(m, dtype=np.int64)
    count = 0
    start = 0
    for i in range(1, m + 1):
        if i == m or np.hypot(x[i] - x[i - 1], y[i] - y[i - 1]) >= jump_m:
            if i - start >= min_points:
                starts[count] = start
                stops[count] = i
                count += 1
            start = i
    return starts[:count].copy(), stops[:count].copy()


@numba.njit(cache=True)
def _centroids(x, y, starts, stops):  # pragma: no cover - compiled
    out = np.empty((starts.size, 2))
    for j in range(starts.size):
        sx = sy = 0.0
        for i in range(starts[j], stops[j]):
            sx += x[i]
            sy += y[i]
        out[j, 0] = sx / (stops[j] - starts[j])
        out[j, 1] = sy / (stops[j] - starts[j])
    return out
