"""Compiled measures of every packed limitation (the packed fast path of ``arm.constraints``).

The constraint classes (``arm.constraints``, ``control.human_constraint``, ``arm.zones``) are the
spec; these loops compute the same rows from flat arrays, each closest-point Jacobian row taken
from the joint placements of one forward-kinematics pass (``packed_kinematics``). Kinds:

===========  ======================================  ==========================================
kind         ``con_real`` (floats)                   rows (``tag`` = constraint, a, b)
===========  ======================================  ==========================================
JOINT        -                                       lower then upper of every limited joint
REACH        shoulder (3), inner, outer              inner, extended
TABLE        height                                  capsules below the activation distance
CAPSULE      p0 (3), p1 (3), radius                  capsules below the activation distance
HALFSPACE    point (3), unit normal (3)              same
BOX          centre (3), half size (3), sphere r     same (bounding-sphere pre-test)
HUMAN        critical, activation                    (capsule, human capsule) pairs below it
===========  ======================================  ==========================================

``con_int`` holds (skip_capsules, first human capsule, human capsule count). A box that a
capsule touches or penetrates returns ``False`` (the caller falls back to the reference path).
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.packed_kinematics import point_jacobian_row
from cobotsafety.geometry.capsule import _capsule_kernel

JOINT, REACH, TABLE, CAPSULE, HALFSPACE, BOX, HUMAN = range(7)
ANGULAR_KINDS = (JOINT,)


@numba.njit(cache=True)
def capsule_points(oR, op, cap_joint, cap_p0l, cap_p1l, p0, p1, origins):  # pragma: no cover - compiled
    """World end points (c, 3) of every robot capsule and their joints' origins, in place."""
    for k in range(cap_joint.shape[0]):
        j = cap_joint[k]
        for r in range(3):
            origins[k, r] = op[j, r]
            p0[k, r] = op[j, r] + oR[j, r, 0] * cap_p0l[k, 0] + oR[j, r, 1] * cap_p0l[k, 1] + oR[j, r, 2] * cap_p0l[k, 2]
            p1[k, r] = op[j, r] + oR[j, r, 0] * cap_p1l[k, 0] + oR[j, r, 1] * cap_p1l[k, 1] + oR[j, r, 2] * cap_p1l[k, 2]


@numba.njit(cache=True)
def box_distance(p0, p1, radius: float, centre, half, out_p, out_u):  # pragma: no cover - compiled
    """``BoxZone.capsule_distances`` for one capsule outside the box: the distance [m], the
    closest point and clearance direction into ``out_p``, ``out_u``. NaN when touching or
    penetrating (the reference's other branch)."""
    x0 = np.empty(3)
    seg = np.empty(3)
    for k in range(3):
        x0[k] = p0[k] - centre[k]
        seg[k] = p1[k] - p0[k]
    knots = np.empty(8)
    knots[0] = 0.0
    knots[7] = 1.0
    for k in range(3):
        for side in range(2):
            bound = half[k] if side == 0 else -half[k]
            value = 1.0
            if seg[k] != 0.0:
                crossing = (bound - x0[k]) / seg[k]
                if np.isfinite(crossing) and crossing > 0.0 and crossing < 1.0:
                    value = crossing
            knots[1 + side * 3 + k] = value
    knots.sort()
    best_f = np.inf
    best_t = 0.0
    for piece in range(7):
        a, b = knots[piece], knots[piece + 1]
        num = 0.0
        den = 0.0
        for k in range(3):
            mid = x0[k] + 0.5 * (a + b) * seg[k]
            if mid > half[k]:
                offset, slope = x0[k] - half[k], seg[k]
            elif mid < -half[k]:
                offset, slope = x0[k] + half[k], seg[k]
            else:
                offset, slope = 0.0, 0.0
            num += offset * slope
            den += slope * slope
        num = -num
        t_star = num / den if den > 1e-18 else a
        t_star = min(max(t_star, a), b)
        f = 0.0
        for k in range(3):
            outside = max(abs(x0[k] + t_star * seg[k]) - half[k], 0.0)
            f += outside * outside
        if f < best_f:
            best_f, best_t = f, t_star
    if best_f <= 1e-24:
        return np.nan
    q_out = np.empty(3)
    norm2 = 0.0
    for k in range(3):
        out_p[k] = p0[k] + best_t * seg[k]
        local = out_p[k] - centre[k]
        q_out[k] = max(abs(local) - half[k], 0.0)
        norm2 += q_out[k] * q_out[k]
    out_norm = np.sqrt(norm2)
    inside = min(max(abs(out_p[0] - centre[0]) - half[0], abs(out_p[1] - centre[1]) - half[1],
                     abs(out_p[2] - centre[2]) - half[2]), 0.0)
    for k in range(3):
        sign = 1.0 if out_p[k] - centre[k] >= 0 else -1.0
        out_u[k] = sign * q_out[k] / out_norm
    return out_norm + inside - radius


@numba.njit(cache=True)
def sphere_lower_bounds(p0, p1, radius, skip: int, centre, sphere_r: float):  # pragma: no cover - compiled
    """Distances (c - skip,) of the capsules to a bounding sphere (the box's cheap lower bound)."""
    n = p0.shape[0] - skip
    c_rep = np.empty((n, 3))
    for i in range(n):
        c_rep[i] = centre
    d, pa, pb = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    _capsule_kernel(p0[skip:], p1[skip:], radius[skip:], c_rep, c_rep, np.full(n, sphere_r), d, pa, pb)
    return d


@numba.njit(cache=True)
def zone_geometry(kind: int, real, p0, p1, radius, skip: int, exact_below: float):  # pragma: no cover - compiled
    """Distances (c - skip,) [m] (box: exact below ``exact_below``, else the sphere bound), the
    exact mask, closest points and directions (c - skip, 3); ``ok`` False for a penetrated box."""
    n = p0.shape[0] - skip
    d = np.empty(n)
    exact = np.ones(n, dtype=np.bool_)
    pts = np.zeros((n, 3))
    dirs = np.zeros((n, 3))
    ok = True
    if kind == CAPSULE:
        z0 = np.empty((n, 3))
        z1 = np.empty((n, 3))
        for i in range(n):
            z0[i] = real[0:3]
            z1[i] = real[3:6]
        pz = np.empty((n, 3))
        _capsule_kernel(p0[skip:], p1[skip:], radius[skip:], z0, z1, np.full(n, real[6]), d, pts, pz)
        for i in range(n):
            gx, gy, gz = pts[i, 0] - pz[i, 0], pts[i, 1] - pz[i, 1], pts[i, 2] - pz[i, 2]
            norm = np.sqrt(gx * gx + gy * gy + gz * gz)
            if norm > 1e-12:
                dirs[i, 0], dirs[i, 1], dirs[i, 2] = gx / norm, gy / norm, gz / norm
            else:
                dirs[i, 2] = 1.0
    elif kind == HALFSPACE:
        for i in range(n):
            s0 = 0.0
            s1 = 0.0
            for k in range(3):
                s0 += (p0[skip + i, k] - real[k]) * real[3 + k]
                s1 += (p1[skip + i, k] - real[k]) * real[3 + k]
            deepest = p0[skip + i] if s0 >= s1 else p1[skip + i]
            d[i] = -max(s0, s1) - radius[skip + i]
            for k in range(3):
                pts[i, k] = deepest[k]
                dirs[i, k] = -real[3 + k]
    else:  # BOX
        d[:] = sphere_lower_bounds(p0, p1, radius, skip, real[0:3], real[6])
        for i in range(n):
            if d[i] < exact_below:
                value = box_distance(p0[skip + i], p1[skip + i], radius[skip + i], real[0:3], real[3:6], pts[i], dirs[i])
                if np.isnan(value):
                    ok = False
                d[i] = value
            else:
                exact[i] = False
    return d, exact, pts, dirs, ok


@numba.njit(cache=True)
def human_pairs(p0, p1, radius, skip: int, hp0, hp1, hr):  # pragma: no cover - compiled
    """Distances (c', k) and closest points (c', k, 3) robot/human, as ``HumanCapsulesConstraint.pairs``."""
    n = p0.shape[0] - skip
    k = hr.shape[0]
    a0, a1, ra = np.empty((n * k, 3)), np.empty((n * k, 3)), np.empty(n * k)
    b0, b1, rb = np.empty((n * k, 3)), np.empty((n * k, 3)), np.empty(n * k)
    for i in range(n):
        for h in range(k):
            row = i * k + h
            a0[row], a1[row], ra[row] = p0[skip + i], p1[skip + i], radius[skip + i]
            b0[row], b1[row], rb[row] = hp0[h], hp1[h], hr[h]
    d, pr, ph = np.empty(n * k), np.empty((n * k, 3)), np.empty((n * k, 3))
    _capsule_kernel(a0, a1, ra, b0, b1, rb, d, pr, ph)
    return d, pr, ph


@numba.njit(cache=True)
def human_minimum(p0, p1, radius, skip: int, hp0, hp1, hr):  # pragma: no cover - compiled
    """The smallest of ``human_pairs``' distances [m] and its closest points (robot, human),
    the first in row-major (robot capsule, human capsule) order on ties; inf and NaN points when
    there is no pair."""
    d, pr, ph = human_pairs(p0, p1, radius, skip, hp0, hp1, hr)
    if d.shape[0] == 0:
        return np.inf, np.full(3, np.nan), np.full(3, np.nan)
    best = 0
    for i in range(1, d.shape[0]):
        if d[i] < d[best]:
            best = i
    return d[best], pr[best].copy(), ph[best].copy()


@numba.njit(cache=True)
def constraint_distances(kind: int, real, ints, q, p_ee, p0, p1, radius, lower, upper, limited,
                         hp0, hp1, hr, exact_below: float):  # pragma: no cover - compiled
    """One constraint's ``distances(state)`` (``exact_below`` = 0) and ``ok``."""
    skip = ints[0]
    if kind == JOINT:
        L = limited.shape[0]
        out = np.empty(2 * L)
        for i in range(L):
            iq = limited[i, 0]
            out[i] = q[iq] - lower[iq]
            out[L + i] = upper[iq] - q[iq]
        return out, True
    if kind == REACH:
        r = np.sqrt((p_ee[0] - real[0]) ** 2 + (p_ee[1] - real[1]) ** 2 + (p_ee[2] - real[2]) ** 2)
        out = np.empty(2)
        out[0], out[1] = r - real[3], real[4] - r
        return out, True
    if kind == TABLE:
        n = p0.shape[0] - skip
        out = np.empty(n)
        for i in range(n):
            out[i] = min(p0[skip + i, 2], p1[skip + i, 2]) - radius[skip + i] - real[0]
        return out, True
    if kind == HUMAN:
        first, count = ints[1], ints[2]
        if count == 0:
            return np.zeros(0), True
        d, _, _ = human_pairs(p0, p1, radius, skip, hp0[first:first + count], hp1[first:first + count],
                              hr[first:first + count])
        return d - real[0], True
    d, _, _, _, ok = zone_geometry(kind, real, p0, p1, radius, skip, exact_below)
    return d, ok


@numba.njit(cache=True)
def measure_rows(kinds, reals, ints, q, p_ee, J_ee, oR, op, p0, p1, radius, origins, cap_joint,
                 axes, idx_v, support, lower, upper, limited, hp0, hp1, hr, hv0, hv1,
                 activation_m: float, dist, A, rate, angular, tag, before, before_start):  # pragma: no cover - compiled
    """Every active measure row (``distance``, ``A``, ``rate``, ``angular``, ``tag``) in the
    reference's order, and each constraint's distances into ``before`` (at ``before_start``).
    Returns ``(row count, ok)``."""
    m = 0
    nv = A.shape[1]
    u = np.zeros(3)
    for con in range(kinds.shape[0]):
        kind, real, skip = kinds[con], reals[con], ints[con, 0]
        start = before_start[con]
        if kind == JOINT:
            L = limited.shape[0]
            for side in range(2):
                for i in range(L):
                    iq, iv = limited[i, 0], limited[i, 1]
                    value = q[iq] - lower[iq] if side == 0 else upper[iq] - q[iq]
                    dist[m] = value
                    before[start + side * L + i] = value
                    A[m, :] = 0.0
                    A[m, iv] = 1.0 if side == 0 else -1.0
                    rate[m], angular[m] = 0.0, True
                    tag[m, 0], tag[m, 1], tag[m, 2] = con, side, i
                    m += 1
        elif kind == REACH:
            ox, oy, oz = p_ee[0] - real[0], p_ee[1] - real[1], p_ee[2] - real[2]
            r = np.sqrt(ox * ox + oy * oy + oz * oz)
            if r > 1e-12:
                u[0], u[1], u[2] = ox / r, oy / r, oz / r
            else:
                u[0], u[1], u[2] = 0.0, 0.0, 1.0
            for side in range(2):
                dist[m] = r - real[3] if side == 0 else real[4] - r
                before[start + side] = dist[m]
                sign = 1.0 if side == 0 else -1.0
                for col in range(nv):
                    A[m, col] = sign * (u[0] * J_ee[0, col] + u[1] * J_ee[1, col] + u[2] * J_ee[2, col])
                rate[m], angular[m] = 0.0, False
                tag[m, 0], tag[m, 1], tag[m, 2] = con, side, 0
                m += 1
        elif kind == TABLE:
            u[0], u[1], u[2] = 0.0, 0.0, 1.0
            for i in range(p0.shape[0] - skip):
                c = skip + i
                low = p0[c] if p0[c, 2] <= p1[c, 2] else p1[c]
                value = low[2] - radius[c] - real[0]
                before[start + i] = min(p0[c, 2], p1[c, 2]) - radius[c] - real[0]
                if value < activation_m:
                    dist[m] = value
                    point_jacobian_row(u, low, cap_joint[c], oR, op, axes, idx_v, support, A[m])
                    rate[m], angular[m] = 0.0, False
                    tag[m, 0], tag[m, 1], tag[m, 2] = con, c, 0
                    m += 1
        elif kind == HUMAN:
            first, count = ints[con, 1], ints[con, 2]
            if count == 0:
                continue
            hp0_, hp1_, hr_ = hp0[first:first + count], hp1[first:first + count], hr[first:first + count]
            d, pr, ph = human_pairs(p0, p1, radius, skip, hp0_, hp1_, hr_)
            n = p0.shape[0] - skip
            for i in range(n):
                for h in range(count):
                    row = i * count + h
                    before[start + row] = d[row] - real[0]
                    if d[row] < real[1]:
                        gx, gy, gz = pr[row, 0] - ph[row, 0], pr[row, 1] - ph[row, 1], pr[row, 2] - ph[row, 2]
                        norm = np.sqrt(gx * gx + gy * gy + gz * gz)
                        if norm > 1e-9:
                            u[0], u[1], u[2] = gx / norm, gy / norm, gz / norm
                        else:
                            u[0], u[1], u[2] = 0.0, 0.0, 1.0
                        s0, s1 = hp0_[h], hp1_[h]
                        sx, sy, sz = s1[0] - s0[0], s1[1] - s0[1], s1[2] - s0[2]
                        length2 = sx * sx + sy * sy + sz * sz
                        t = ((ph[row, 0] - s0[0]) * sx + (ph[row, 1] - s0[1]) * sy + (ph[row, 2] - s0[2]) * sz) / length2 \
                            if length2 > 0 else 0.0
                        t = min(max(t, 0.0), 1.0)
                        v0, v1 = hv0[first + h], hv1[first + h]
                        closing = 0.0
                        for k in range(3):
                            closing += u[k] * (v0[k] + t * (v1[k] - v0[k]))
                        dist[m] = d[row] - real[0]
                        point_jacobian_row(u, pr[row], cap_joint[skip + i], oR, op, axes, idx_v, support, A[m])
                        rate[m], angular[m] = -closing, False
                        tag[m, 0], tag[m, 1], tag[m, 2] = con, skip + i, h
                        m += 1
        else:
            d, exact, pts, dirs, ok = zone_geometry(kind, real, p0, p1, radius, skip, activation_m)
            if not ok:
                return m, False
            for i in range(d.shape[0]):
                before[start + i] = d[i]
                if exact[i] and d[i] < activation_m:
                    dist[m] = d[i]
                    point_jacobian_row(dirs[i], pts[i], cap_joint[skip + i], oR, op, axes, idx_v, support, A[m])
                    rate[m], angular[m] = 0.0, False
                    tag[m, 0], tag[m, 1], tag[m, 2] = con, skip + i, 0
                    m += 1
    return m, True
