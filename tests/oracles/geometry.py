"""Segment, capsule and box distances written plainly (numpy, no compiled code)."""

from __future__ import annotations

import numpy as np


def segment_points(a0, a1, b0, b1) -> tuple[np.ndarray, np.ndarray]:
    """The closest points of segments a0-a1 and b0-b1: the minimum of ``|a(s) - b(t)|`` over
    the unit square, from every candidate where it can be (the lines' interior stationary
    point, and each edge of the square with the other parameter optimal and clamped)."""
    a0, a1, b0, b1 = (np.asarray(x, dtype=float) for x in (a0, a1, b0, b1))
    d1, d2, r = a1 - a0, b1 - b0, a0 - b0
    candidates = []
    G = np.array([[d1 @ d1, -(d1 @ d2)], [-(d1 @ d2), d2 @ d2]])
    if abs(np.linalg.det(G)) > 1e-14 * max(1.0, G[0, 0] * G[1, 1]):
        s, t = np.linalg.solve(G, [-(d1 @ r), d2 @ r])
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            candidates.append((s, t))
    for s in (0.0, 1.0):  # an end of A, the closest point of B
        t = ((a0 + s * d1 - b0) @ d2) / (d2 @ d2) if d2 @ d2 > 0 else 0.0
        candidates.append((s, min(max(t, 0.0), 1.0)))
    for t in (0.0, 1.0):  # an end of B, the closest point of A
        s = ((b0 + t * d2 - a0) @ d1) / (d1 @ d1) if d1 @ d1 > 0 else 0.0
        candidates.append((min(max(s, 0.0), 1.0), t))
    best = min(candidates, key=lambda st: float(np.sum((a0 + st[0] * d1 - b0 - st[1] * d2) ** 2)))
    return a0 + best[0] * d1, b0 + best[1] * d2


def capsule_pair(a0, a1, ra, b0, b1, rb) -> tuple[float, np.ndarray, np.ndarray]:
    """``(distance [m], axis point of A, axis point of B)``: the axis distance minus both radii."""
    pa, pb = segment_points(a0, a1, b0, b1)
    return float(np.linalg.norm(pa - pb)) - ra - rb, pa, pb


def unit(v: np.ndarray, fallback) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else np.asarray(fallback, dtype=float)


def point_box(p, c, h) -> tuple[float, np.ndarray]:
    """Signed distance of point ``p`` to the box ``c`` +- ``h`` (negative inside) and the unit
    direction that increases it (inside: the nearest face's normal)."""
    local = np.asarray(p, dtype=float) - c
    q = np.abs(local) - h
    outside = np.maximum(q, 0.0)
    out_norm = float(np.linalg.norm(outside))
    sign = np.where(local >= 0, 1.0, -1.0)
    if out_norm > 0:
        return out_norm, sign * outside / out_norm
    axis = int(np.argmax(q))
    u = np.zeros(3)
    u[axis] = sign[axis]
    return float(q.max()), u


def segment_box(p0, p1, c, h) -> tuple[float, np.ndarray, np.ndarray]:
    """Signed distance of segment p0-p1 to the box, the segment's closest point and the
    clearance direction (``arm/zones.py``'s ``BoxZone``, one segment at a time).

    Outside: the squared outside distance along the segment is a convex piecewise quadratic of
    the segment parameter, pieces split where a coordinate crosses a face plane; each piece's
    minimiser is closed-form. Touching or inside: the signed distance max_k(sigma x_k - h_k) is
    piecewise linear along the segment, so its minimum is at an end, at the outside optimum or
    where two of the six face functions cross; at such a crossing of two faces the minimum
    moves with both, so its gradient is the slope-weighted mix of their normals."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    c, h = np.asarray(c, dtype=float), np.asarray(h, dtype=float)
    x0, seg = p0 - c, p1 - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        crossings = np.concatenate([(h - x0) / seg, (-h - x0) / seg])
    crossings = np.where(np.isfinite(crossings) & (crossings > 0) & (crossings < 1), crossings, 1.0)
    knots = np.sort(np.concatenate([[0.0], crossings, [1.0]]))
    best_f, best_t = np.inf, 0.0
    for lo, hi in zip(knots[:-1], knots[1:]):
        mid = x0 + 0.5 * (lo + hi) * seg
        num = den = 0.0
        for k in range(3):
            if mid[k] > h[k]:
                num -= (x0[k] - h[k]) * seg[k]
                den += seg[k] ** 2
            elif mid[k] < -h[k]:
                num -= (x0[k] + h[k]) * seg[k]
                den += seg[k] ** 2
        t = min(max(num / den if den > 1e-18 else lo, lo), hi)
        f = float(np.sum(np.maximum(np.abs(x0 + t * seg) - h, 0.0) ** 2))
        if f < best_f:
            best_f, best_t = f, t
    if best_f > 1e-24:
        p = p0 + best_t * seg
        d, u = point_box(p, c, h)
        return d, p, u
    sigma = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0])
    axis = np.array([0, 1, 2, 0, 1, 2])
    slopes = sigma * seg[axis]
    values0 = sigma * x0[axis] - h[axis]
    candidates = []
    for i in range(6):
        for j in range(i + 1, 6):
            den = slopes[i] - slopes[j]
            cross = (values0[j] - values0[i]) / den if den != 0.0 else np.nan
            candidates.append(min(max(cross, 0.0), 1.0) if np.isfinite(cross) else 0.0)
    candidates += [0.0, 1.0, best_t]
    sdf = [point_box(p0 + t * seg, c, h)[0] for t in candidates]
    t = candidates[int(np.argmin(sdf))]
    p = p0 + t * seg
    d, u = point_box(p, c, h)
    faces = values0 + t * slopes
    top = faces.max()
    active = np.flatnonzero(np.abs(faces - top) < 1e-12)
    if len(active) == 2 and top < 0.0:
        k, l = active
        if slopes[k] * slopes[l] < 0.0:
            normal = np.zeros((6, 3))
            normal[np.arange(6), axis] = sigma
            u = (slopes[l] * normal[k] - slopes[k] * normal[l]) / (slopes[l] - slopes[k])
    return d, p, u
