"""Context features of a laser cluster: what lies around it in the same scan.

A cluster's own shape (``leg_features``) cannot tell a leg from a chair or table leg of the same
width: the leave-one-bag-out forest on shape alone called five static objects of the
leg_tracker room legs in nearly every scan. What is around them differs: furniture legs stand
beside other furniture and walls, a walking person's legs in open floor with the other leg
0.1-0.5 m away. Per cluster, against every usable return of the scan (also the returns of
clusters too short to keep) and every other kept cluster:

* ``nearest_return_m``: distance from the cluster's centroid to the nearest return that is not
  its own (``CONTEXT_CAP_M`` when there is none or it is farther);
* ``returns_within_0_5_m``, ``returns_within_1_m``: how many such returns lie within 0.5 m and
  1 m of the centroid;
* ``nearest_cluster_m``: distance to the nearest other cluster's centroid (capped likewise);
* ``nearest_cluster_width_m``: that cluster's width, first to last return (0 when alone).

``context_reference`` is the readable numpy version, ``context_kernel`` the compiled one
(called by ``leg_features.cluster_features``); a test holds the two equal.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.sensors.leg_clusters import Clusters

CONTEXT_NAMES = ("nearest_return_m", "returns_within_0_5_m", "returns_within_1_m", "nearest_cluster_m",
                 "nearest_cluster_width_m")
N_CONTEXT = len(CONTEXT_NAMES)
#: Distances [m] are capped here (and a cluster alone in its scan gets this).
CONTEXT_CAP_M = 3.0
NEAR_M, AROUND_M = 0.5, 1.0


def context_reference(clusters: Clusters, rows: np.ndarray) -> np.ndarray:
    """Shape (len(rows), N_CONTEXT): the context of clusters ``rows`` (readable version)."""
    points = np.column_stack([clusters.x_m, clusters.y_m])
    centroids, widths = clusters.centroids(), clusters.widths()
    out = np.zeros((len(rows), N_CONTEXT))
    for i, j in enumerate(np.asarray(rows, dtype=np.int64).tolist()):
        own = np.zeros(points.shape[0], dtype=bool)
        own[clusters.starts[j]:clusters.stops[j]] = True
        d = np.linalg.norm(points[~own] - centroids[j], axis=1)
        out[i, 0] = min(d.min(), CONTEXT_CAP_M) if d.size else CONTEXT_CAP_M
        out[i, 1] = np.sum(d < NEAR_M)
        out[i, 2] = np.sum(d < AROUND_M)
        dc = np.linalg.norm(centroids - centroids[j], axis=1)
        dc[j] = np.inf
        if clusters.count > 1:
            k = int(np.argmin(dc))
            out[i, 3], out[i, 4] = min(dc[k], CONTEXT_CAP_M), widths[k]
        else:
            out[i, 3], out[i, 4] = CONTEXT_CAP_M, 0.0
    return out


@numba.njit(cache=True)
def context_kernel(x, y, starts, stops, rows, out, column):
    """Write the context of clusters ``rows`` into ``out[:, column:column + N_CONTEXT]``."""
    c = starts.size
    cx = np.empty(c)
    cy = np.empty(c)
    width = np.empty(c)
    for k in range(c):
        s, e = starts[k], stops[k]
        sx = sy = 0.0
        for i in range(s, e):
            sx += x[i]
            sy += y[i]
        cx[k], cy[k] = sx / (e - s), sy / (e - s)
        width[k] = np.hypot(x[e - 1] - x[s], y[e - 1] - y[s])
    for r in range(rows.size):
        j = rows[r]
        s, e = starts[j], stops[j]
        nearest = CONTEXT_CAP_M
        near = around = 0
        for i in range(x.size):
            if s <= i < e:
                continue
            d = np.hypot(x[i] - cx[j], y[i] - cy[j])
            nearest = min(nearest, d)
            if d < NEAR_M:
                near += 1
            if d < AROUND_M:
                around += 1
        best, best_k = np.inf, -1
        for k in range(c):
            if k != j:
                d = np.hypot(cx[k] - cx[j], cy[k] - cy[j])
                if d < best:
                    best, best_k = d, k
        out[r, column] = nearest
        out[r, column + 1] = near
        out[r, column + 2] = around
        out[r, column + 3] = min(best, CONTEXT_CAP_M) if best_k >= 0 else CONTEXT_CAP_M
        out[r, column + 4] = width[best_k] if best_k >= 0 else 0.0
