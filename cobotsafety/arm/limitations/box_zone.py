"""An axis-aligned box zone: every robot capsule stays out of it.

Rows (metres): the signed clearance between each robot capsule (from ``skip_capsules`` on) and
the box — the segment-box distance minus the capsule's radius, negative inside — and its
gradient ``u . J_p`` at the segment's closest point ``p``, ``u`` the direction in which moving
that point increases the clearance; and the same at each end of the segment (the point-box
distance). A capsule lying along a face has every point at one distance, and its closest point
jumps from one end to the other as it tilts: the end arriving has been braked by its own row,
where the closest point's row alone met it at full speed. An end's row is left out while it is
the closest point (the same row twice). ``before``: three distances per capsule (the closest
point's, then the ends').

Segment-box distance, exactly: along the segment the squared outside distance is a convex
piecewise quadratic of the segment parameter, with pieces split where a coordinate crosses a
face plane; each piece's minimiser is closed-form. A segment touching or inside the box gets the
box's signed distance minimised exactly: inside, ``max_k(sigma x_k - h_k)`` is piecewise linear
along the segment, so its minimum is at an end or where two of the six face functions cross;
at such a crossing the minimum moves with both faces, so its gradient with respect to a
translation is the slope-weighted mix of their normals. A capsule far from the box is first
tested against the box's circumscribed sphere (a cheap lower bound of the distance).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import write_point_row
from cobotsafety.geometry.capsule import capsule_pair

KIND = 5
ANGULAR = False


@dataclass(frozen=True)
class BoxZone:
    """The box ``center`` +- ``half_size`` [m] (base frame, axis-aligned)."""

    name: str
    center: tuple[float, float, float]
    half_size: tuple[float, float, float]
    skip_capsules: int = 1

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        """``(centre (3,), radius)`` [m] of the sphere through the corners."""
        return np.asarray(self.center, dtype=float), float(np.linalg.norm(self.half_size))


def pack(zone: BoxZone, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    centre, sphere_r = zone.bounding_sphere()
    real[0:3], real[3:6], real[6] = centre, zone.half_size, sphere_r
    return real, zone.skip_capsules


def row_name(zone: BoxZone, robot, a: int, b: int) -> str:
    return f"{zone.name} ({robot.capsules[a].name})"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 3 * max(n_caps - skip, 0)


@numba.njit(cache=True)
def _point_box(p, c, h, out_u):  # pragma: no cover - compiled
    """Signed distance [m] of the point ``p`` (3,) to the box, and into ``out_u`` the direction
    that increases it."""
    norm2 = 0.0
    q_max = -np.inf
    axis = 0
    for k in range(3):
        qk = abs(p[k] - c[k]) - h[k]
        if qk > q_max:
            q_max, axis = qk, k
        if qk > 0.0:
            norm2 += qk * qk
    out_norm = np.sqrt(norm2)
    for k in range(3):
        sign = 1.0 if p[k] - c[k] >= 0 else -1.0
        if out_norm > 0.0:
            out_u[k] = sign * max(abs(p[k] - c[k]) - h[k], 0.0) / out_norm
        else:
            out_u[k] = sign if k == axis else 0.0
    return out_norm + min(q_max, 0.0)


@numba.njit(cache=True)
def segment_box(a, b, c, h, out_p, out_u):  # pragma: no cover - compiled
    """Signed distance [m] of the segment ``a``-``b`` (3,) to the box centre ``c`` half size
    ``h``; the segment's closest point into ``out_p`` and the clearance direction into ``out_u``."""
    x0 = a - c
    seg = b - a
    knots = np.empty(8)
    knots[0], knots[7] = 0.0, 1.0
    for k in range(3):
        for side in range(2):
            face = h[k] if side == 0 else -h[k]
            value = 1.0
            if seg[k] != 0.0:
                crossing = (face - x0[k]) / seg[k]
                if np.isfinite(crossing) and 0.0 < crossing < 1.0:
                    value = crossing
            knots[1 + side * 3 + k] = value
    knots.sort()
    best_f, best_t = np.inf, 0.0
    for piece in range(7):
        lo, hi = knots[piece], knots[piece + 1]
        num, den = 0.0, 0.0
        for k in range(3):
            mid = x0[k] + 0.5 * (lo + hi) * seg[k]
            if mid > h[k]:
                num -= (x0[k] - h[k]) * seg[k]
                den += seg[k] * seg[k]
            elif mid < -h[k]:
                num -= (x0[k] + h[k]) * seg[k]
                den += seg[k] * seg[k]
        t_star = num / den if den > 1e-18 else lo
        t_star = min(max(t_star, lo), hi)
        f = 0.0
        for k in range(3):
            outside = max(abs(x0[k] + t_star * seg[k]) - h[k], 0.0)
            f += outside * outside
        if f < best_f:
            best_f, best_t = f, t_star
    t = best_t
    if best_f > 1e-24:
        for k in range(3):
            out_p[k] = a[k] + t * seg[k]
        return _point_box(out_p, c, h, out_u)
    # Touching or inside: the signed distance's minimum among the ends, the outside optimum
    # and the crossings of two of the six face functions sigma x_k - h_k.
    slopes = np.empty(6)
    values0 = np.empty(6)
    for side in range(2):
        sigma = 1.0 if side == 0 else -1.0
        for k in range(3):
            slopes[3 * side + k] = sigma * seg[k]
            values0[3 * side + k] = sigma * x0[k] - h[k]
    candidates = np.empty(18)
    n_cand = 0
    for i in range(6):
        for j in range(i + 1, 6):
            den = slopes[i] - slopes[j]
            cross = (values0[j] - values0[i]) / den if den != 0.0 else np.nan
            candidates[n_cand] = min(max(cross, 0.0), 1.0) if np.isfinite(cross) else 0.0
            n_cand += 1
    candidates[15], candidates[16], candidates[17] = 0.0, 1.0, best_t
    best_sdf, pick = np.inf, 0.0
    point = np.empty(3)
    scratch = np.empty(3)
    for i in range(18):
        for k in range(3):
            point[k] = a[k] + candidates[i] * seg[k]
        sdf = _point_box(point, c, h, scratch)
        if sdf < best_sdf:
            best_sdf, pick = sdf, candidates[i]
    t = pick
    for k in range(3):
        out_p[k] = a[k] + t * seg[k]
    d = _point_box(out_p, c, h, out_u)
    top = -np.inf
    for i in range(6):
        top = max(top, values0[i] + t * slopes[i])
    first, second, n_active = -1, -1, 0
    for i in range(6):
        if abs(values0[i] + t * slopes[i] - top) < 1e-12:
            if n_active == 0:
                first = i
            elif n_active == 1:
                second = i
            n_active += 1
    if n_active == 2 and top < 0.0:
        s_k, s_l = slopes[first], slopes[second]
        if s_k * s_l < 0.0:
            denom = s_l - s_k
            for k in range(3):
                out_u[k] = 0.0
            out_u[first % 3] += (s_l / denom) * (1.0 if first < 3 else -1.0)
            out_u[second % 3] -= (s_k / denom) * (1.0 if second < 3 else -1.0)
    return d


@numba.njit(cache=True, inline="always")
def _same_point(a, b):  # pragma: no cover - compiled
    """Whether ``a`` and ``b`` are one point (to 1e-9 m: ``segment_box``'s ``a + t (b - a)``
    at ``t = 1`` rounds)."""
    return abs(a[0] - b[0]) <= 1e-9 and abs(a[1] - b[1]) <= 1e-9 and abs(a[2] - b[2]) <= 1e-9


@numba.njit(cache=True)
def _clearance(real, skip, kin, c, exact_below, pa, u):  # pragma: no cover - compiled
    """Capsule ``c``'s clearance [m]: exact below ``exact_below``, else the sphere's lower
    bound; whether it is exact."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pb = np.empty(3)
    bound = capsule_pair(p0[c], p1[c], radius[c], real[0:3], real[0:3], real[6], pa, pb)
    if bound >= exact_below:
        return bound, False
    return segment_box(p0[c], p1[c], real[0:3], real[3:6], pa, u) - radius[c], True


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    p0, p1, radius = kin[5], kin[6], kin[7]
    pa, u = np.empty(3), np.empty(3)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        out[3 * i], _ = _clearance(real, skip, kin, c, 0.0, pa, u)
        out[3 * i + 1] = _point_box(p0[c], real[0:3], real[3:6], u) - radius[c]
        out[3 * i + 2] = _point_box(p1[c], real[0:3], real[3:6], u) - radius[c]


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pa, u = np.empty(3), np.empty(3)
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        value, exact = _clearance(real, skip, kin, c, activation_m, pa, u)
        before[3 * i] = value
        if exact and value < activation_m:
            m = write_point_row(out, m, value, u, pa, c, 0.0, con, 0, kin, scratch)
        for end in range(2):
            point = p0[c] if end == 0 else p1[c]
            value = _point_box(point, real[0:3], real[3:6], u) - radius[c]
            before[3 * i + 1 + end] = value
            if value >= activation_m or (exact and _same_point(point, pa)):
                continue
            m = write_point_row(out, m, value, u, point, c, 0.0, con, 1 + end, kin, scratch)
    return m
