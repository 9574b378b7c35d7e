"""Geometric features of laser clusters, the input of the leg classifier.

One row per cluster (``leg_clusters.segment``), one column per entry of ``FEATURE_NAMES``
(after Arras et al. 2007, "Using boosted features for the detection of people in 2D range
data", and the leg_tracker package): how many returns and how wide, how straight (RMS residual
to the best line), how round (RMS residual to the best circle, its radius, whether its centre
lies behind the points as a leg's does), how long and regular the polyline, its curvature and
turning, the inscribed angle (constant along a circular arc), its range, and the range jumps to
the beams on either side (positive: the neighbour is farther; a no-return neighbour counts as
``JUMP_CAP_M`` farther).

The last columns are the cluster's context in its scan (``leg_context``): the nearest other
return and cluster, how many returns around it.

``features_reference`` is the readable numpy version (one cluster at a time);
``cluster_features`` runs the same maths compiled (``numba``), all clusters in one call. A test
holds the two equal.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.leg_clusters import Clusters
from cobotsafety.sensors.leg_context import CONTEXT_NAMES, context_kernel, context_reference

SHAPE_NAMES = (
    "n_points", "beam_span_m", "std_m", "mean_abs_dev_median_m", "width_m", "linearity_m",
    "circularity_m", "radius_m", "boundary_length_m", "boundary_regularity_m",
    "mean_curvature_1_m", "mean_angular_difference_rad", "inscribed_angle_mean_rad",
    "inscribed_angle_std_rad", "range_m", "jump_before_m", "jump_after_m", "convexity_m",
)
N_SHAPE = len(SHAPE_NAMES)
FEATURE_NAMES = SHAPE_NAMES + CONTEXT_NAMES
N_FEATURES = len(FEATURE_NAMES)
#: Range jumps are clipped to +-JUMP_CAP_M [m]; a no-return neighbour is JUMP_CAP_M farther.
JUMP_CAP_M = 1.0
#: Largest circle radius [m] reported (a straight cluster's circle is unbounded).
RADIUS_CAP_M = 10.0
#: The circle fit is degenerate when its 2x2 system's determinant is below this share of
#: the squared trace (the points are collinear).
_DEGENERATE = 1e-12


def _jump(neighbour: int, edge_range_m: float, ranges: np.ndarray, valid: np.ndarray) -> float:
    if 0 <= neighbour < ranges.size and valid[neighbour]:
        return float(np.clip(ranges[neighbour] - edge_range_m, -JUMP_CAP_M, JUMP_CAP_M))
    return JUMP_CAP_M


def _angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unsigned angles [rad] between the rows of u and v, shape (k,)."""
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    dot = (u * v).sum(axis=1)
    return np.abs(np.arctan2(cross, dot))


def _rows(clusters: Clusters, rows: np.ndarray | None) -> np.ndarray:
    return np.arange(clusters.count, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)


def features_reference(scan: LaserScan, clusters: Clusters, rows: np.ndarray | None = None) -> np.ndarray:
    """Shape (len(rows), N_FEATURES): the features of clusters ``rows`` (default all), their
    context among all of ``clusters`` (readable numpy version)."""
    rows = _rows(clusters, rows)
    shape = []
    for start, stop in zip(clusters.starts[rows].tolist(), clusters.stops[rows].tolist()):
        p = np.column_stack([clusters.x_m[start:stop], clusters.y_m[start:stop]])
        r = clusters.ranges_m[start:stop]
        first, last = int(clusters.beams[start]), int(clusters.beams[stop - 1])
        m = p.shape[0]
        centroid = p.mean(axis=0)
        d = p - centroid
        range_m = float(np.hypot(*centroid))
        # Line: the smallest eigenvalue of the covariance is the mean squared residual.
        linearity = float(np.sqrt(max(np.linalg.eigvalsh(d.T @ d / m)[0], 0.0)))
        # Circle (Kasa's algebraic fit, centred): u^2 + v^2 + a u + b v + c = 0.
        z = (d ** 2).sum(axis=1)
        normal = d.T @ d
        det = normal[0, 0] * normal[1, 1] - normal[0, 1] ** 2
        if det <= _DEGENERATE * np.trace(normal) ** 2:
            radius, circularity, convexity = RADIUS_CAP_M, linearity, 0.0
        else:
            a, b = np.linalg.solve(normal, -(d * z[:, None]).sum(axis=0))
            centre = np.array([-a / 2, -b / 2])
            radius_raw = float(np.sqrt(max(centre @ centre + z.mean(), 0.0)))
            circularity = float(np.sqrt(np.mean((np.linalg.norm(d - centre, axis=1) - radius_raw) ** 2)))
            radius = min(radius_raw, RADIUS_CAP_M)
            convexity = float(np.clip(np.hypot(*(centre + centroid)) - range_m, -JUMP_CAP_M, JUMP_CAP_M))
        steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
        prev, nxt = p[1:-1] - p[:-2], p[2:] - p[1:-1]
        chord = np.linalg.norm(p[2:] - p[:-2], axis=1)
        area2 = np.abs(prev[:, 0] * nxt[:, 1] - prev[:, 1] * nxt[:, 0])
        lengths = steps[:-1] * steps[1:] * chord
        curvature = np.where(lengths > 0, 2 * area2 / np.where(lengths > 0, lengths, 1.0), 0.0)
        inscribed = _angle_between(p[0] - p[1:-1], p[-1] - p[1:-1])
        shape.append([
            m,
            range_m * abs(scan.angle_increment) * (last - first),
            float(np.sqrt(np.mean(z))),
            float(np.mean(np.linalg.norm(p - np.median(p, axis=0), axis=1))),
            float(np.linalg.norm(p[-1] - p[0])),
            linearity,
            circularity,
            radius,
            float(steps.sum()),
            float(steps.std()),
            float(curvature.mean()),
            float(_angle_between(prev, nxt).mean()),
            float(inscribed.mean()),
            float(inscribed.std()),
            range_m,
            _jump(first - 1, float(r[0]), scan.ranges, scan.valid),
            _jump(last + 1, float(r[-1]), scan.ranges, scan.valid),
            convexity,
        ])
    return np.hstack([np.array(shape, dtype=float).reshape(-1, N_SHAPE), context_reference(clusters, rows)])


def cluster_features(scan: LaserScan, clusters: Clusters, rows: np.ndarray | None = None) -> np.ndarray:
    """Shape (len(rows), N_FEATURES): the features of clusters ``rows`` (default all), their
    context among all of ``clusters`` (compiled; equals the reference)."""
    rows = _rows(clusters, rows)
    out = np.empty((rows.size, N_FEATURES))
    _features_kernel(clusters.x_m, clusters.y_m, clusters.ranges_m, clusters.beams, clusters.starts,
                     clusters.stops, rows, scan.ranges, scan.valid, abs(float(scan.angle_increment)), out)
    context_kernel(clusters.x_m, clusters.y_m, clusters.starts, clusters.stops, rows, out, N_SHAPE)
    return out


@numba.njit(cache=True)
def _angle(ux, uy, vx, vy):
    return abs(np.arctan2(ux * vy - uy * vx, ux * vx + uy * vy))


@numba.njit(cache=True)
def _jump_kernel(neighbour, edge, ranges, valid):
    if 0 <= neighbour < ranges.size and valid[neighbour]:
        return min(max(ranges[neighbour] - edge, -JUMP_CAP_M), JUMP_CAP_M)
    return JUMP_CAP_M


@numba.njit(cache=True)
def _features_kernel(x, y, r, beams, starts, stops, rows, scan_ranges, scan_valid, increment, out):
    """Write the shape features of clusters ``rows`` into ``out[:, :N_SHAPE]``."""
    for j in range(rows.size):
        s, e = starts[rows[j]], stops[rows[j]]
        m = e - s
        px, py = x[s:e], y[s:e]
        cx, cy = px.mean(), py.mean()
        range_m = np.hypot(cx, cy)
        suu = suv = svv = suz = svz = zsum = 0.0
        for i in range(m):
            u, v = px[i] - cx, py[i] - cy
            zi = u * u + v * v
            suu += u * u
            suv += u * v
            svv += v * v
            suz += u * zi
            svz += v * zi
            zsum += zi
        # Smallest eigenvalue of [[suu, suv], [suv, svv]] / m.
        half_trace, det = (suu + svv) / 2.0, suu * svv - suv * suv
        lam = half_trace - np.sqrt(max(half_trace * half_trace - det, 0.0))
        linearity = np.sqrt(max(lam / m, 0.0))
        if det <= _DEGENERATE * (suu + svv) ** 2:
            radius, circularity, convexity = RADIUS_CAP_M, linearity, 0.0
        else:
            a = (-suz * svv + svz * suv) / det
            b = (-svz * suu + suz * suv) / det
            ox, oy = -a / 2.0, -b / 2.0
            radius_raw = np.sqrt(max(ox * ox + oy * oy + zsum / m, 0.0))
            acc = 0.0
            for i in range(m):
                res = np.hypot(px[i] - cx - ox, py[i] - cy - oy) - radius_raw
                acc += res * res
            circularity = np.sqrt(acc / m)
            radius = min(radius_raw, RADIUS_CAP_M)
            convexity = min(max(np.hypot(ox + cx, oy + cy) - range_m, -JUMP_CAP_M), JUMP_CAP_M)
        mx, my = np.median(px), np.median(py)
        mad = 0.0
        for i in range(m):
            mad += np.hypot(px[i] - mx, py[i] - my)
        length = 0.0
        for i in range(m - 1):
            length += np.hypot(px[i + 1] - px[i], py[i + 1] - py[i])
        mean_step = length / (m - 1)
        spread = 0.0
        for i in range(m - 1):
            spread += (np.hypot(px[i + 1] - px[i], py[i + 1] - py[i]) - mean_step) ** 2
        curvature = turning = ins_sum = ins_sq = 0.0
        for i in range(1, m - 1):
            ax, ay = px[i] - px[i - 1], py[i] - py[i - 1]
            bx, by = px[i + 1] - px[i], py[i + 1] - py[i]
            lengths = np.hypot(ax, ay) * np.hypot(bx, by) * np.hypot(px[i + 1] - px[i - 1], py[i + 1] - py[i - 1])
            if lengths > 0:
                curvature += 2.0 * abs(ax * by - ay * bx) / lengths
            turning += _angle(ax, ay, bx, by)
            ins = _angle(px[0] - px[i], py[0] - py[i], px[m - 1] - px[i], py[m - 1] - py[i])
            ins_sum += ins
        inner = m - 2
        ins_mean = ins_sum / inner
        for i in range(1, m - 1):
            ins = _angle(px[0] - px[i], py[0] - py[i], px[m - 1] - px[i], py[m - 1] - py[i])
            ins_sq += (ins - ins_mean) ** 2
        first, last = beams[s], beams[e - 1]
        out[j, 0] = m
        out[j, 1] = range_m * increment * (last - first)
        out[j, 2] = np.sqrt(zsum / m)
        out[j, 3] = mad / m
        out[j, 4] = np.hypot(px[m - 1] - px[0], py[m - 1] - py[0])
        out[j, 5] = linearity
        out[j, 6] = circularity
        out[j, 7] = radius
        out[j, 8] = length
        out[j, 9] = np.sqrt(spread / (m - 1))
        out[j, 10] = curvature / inner
        out[j, 11] = turning / inner
        out[j, 12] = ins_mean
        out[j, 13] = np.sqrt(ins_sq / inner)
        out[j, 14] = range_m
        out[j, 15] = _jump_kernel(first - 1, r[s], scan_ranges, scan_valid)
        out[j, 16] = _jump_kernel(last + 1, r[e - 1], scan_ranges, scan_valid)
        out[j, 17] = convexity
