"""The human as a moving zone: every robot capsule keeps ``critical_m`` from every human capsule.

Rows (metres) for every (robot capsule from ``skip_capsules`` on, human capsule) pair whose
capsule distance is below ``activation_m``: ``d = distance - critical_m``, gradient ``u . J_p``
at the robot capsule's closest axis point (``u`` the unit vector from the human's closest
point), and the rate at which the human alone changes ``d``: ``-u . v_h``, ``v_h`` the human's
velocity at its closest point (interpolated between its capsule's end-point velocities). The
human's capsules reach the compiled step as one flat buffer (``human_buffer``), extrapolated
there to the step's time with their velocities.

Defaults: ``critical_m`` = 0.25 m (paper 2's d_cr is not given numerically: a quarter metre
between capsule surfaces) and ``activation_m`` = 0.60 m (d_cr + d_o with d_o = 0.35 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import direction_from, write_point_row
from cobotsafety.geometry.capsule import all_pairs, capsule_pair

KIND = 6
ANGULAR = False
DEFAULT_CRITICAL_M = 0.25
DEFAULT_ACTIVATION_M = 0.60
#: Floats per human capsule in the flat buffer: p0 (3), p1 (3), radius, v0 (3), v1 (3).
HUMAN_FLOATS = 13


@dataclass(frozen=True)
class HumanLimitation:
    """Keeps ``critical_m`` [m] between robot and human capsules; rows below ``activation_m`` [m]."""

    critical_m: float = DEFAULT_CRITICAL_M
    activation_m: float = DEFAULT_ACTIVATION_M
    skip_capsules: int = 1
    name: str = "human"


def pack(limitation: HumanLimitation, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    real[0], real[1] = limitation.critical_m, limitation.activation_m
    return real, limitation.skip_capsules


def row_name(limitation: HumanLimitation, robot, a: int, b: int, human_names: tuple[str, ...] = ()) -> str:
    part = human_names[b] if b < len(human_names) else f"capsule {b}"
    return f"human {part} ({robot.capsules[a].name})"


@numba.njit(cache=True)
def human_buffer(p0_m, p1_m, radius_m, v0_m_s, v1_m_s):  # pragma: no cover - compiled
    """The flat buffer (13 h,) the compiled step reads: end points (h, 3) [m], radii (h,) [m]
    and end-point velocities (h, 3) [m/s], in that order (``HUMAN_FLOATS`` per capsule), each a
    float64 ``numpy`` array (as ``HumanCapsules`` holds them). (Compiled: numpy's concatenation
    of the five cost half as much again, at every human frame.)"""
    h = radius_m.shape[0]
    out = np.empty(HUMAN_FLOATS * h)
    for i in range(h):
        for k in range(3):
            out[3 * i + k] = p0_m[i, k]
            out[3 * h + 3 * i + k] = p1_m[i, k]
            out[7 * h + 3 * i + k] = v0_m_s[i, k]
            out[10 * h + 3 * i + k] = v1_m_s[i, k]
        out[6 * h + i] = radius_m[i]
    return out


@numba.njit(cache=True)
def unpack_human(human_f, ahead_s):  # pragma: no cover - compiled
    """``(p0 (h, 3), p1 (h, 3), radius (h,), v0 (h, 3), v1 (h, 3))`` from the flat buffer, the
    end points moved ``ahead_s`` [s] along their velocities (new arrays)."""
    h = human_f.shape[0] // HUMAN_FLOATS
    v0 = human_f[7 * h:10 * h].reshape((h, 3))
    v1 = human_f[10 * h:13 * h].reshape((h, 3))
    p0 = human_f[0:3 * h].reshape((h, 3)) + ahead_s * v0
    p1 = human_f[3 * h:6 * h].reshape((h, 3)) + ahead_s * v1
    return p0, p1, human_f[6 * h:7 * h], v0, v1


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return max(n_caps - skip, 0) * n_human


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    """``distance - critical`` of every pair, robot-major, into ``out``."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    hp0, hp1, hr, hv0, hv1 = human
    d, _, _ = all_pairs(p0, p1, radius, skip, hp0, hp1, hr)
    n, k = d.shape
    for i in range(n):
        for h in range(k):
            out[i * k + h] = d[i, h] - real[0]


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    """The pairs within ``activation_m`` (the limitation's own ``real[1]``, or farther for a
    person walking at the arm: see ``arm_step``)."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    hp0, hp1, hr, hv0, hv1 = human
    pa, pb, u = np.empty(3), np.empty(3), np.empty(3)
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    ds, pas, pbs = all_pairs(p0, p1, radius, skip, hp0, hp1, hr)
    n, k = ds.shape
    for i in range(n):
        c = skip + i
        for h in range(k):
            d = ds[i, h]
            before[i * k + h] = d - real[0]
            if d >= activation_m:
                continue
            for r in range(3):
                pa[r], pb[r] = pas[i, h, r], pbs[i, h, r]
            direction_from(pb, pa, 1e-9, u)
            sx, sy, sz = hp1[h, 0] - hp0[h, 0], hp1[h, 1] - hp0[h, 1], hp1[h, 2] - hp0[h, 2]
            length2 = sx * sx + sy * sy + sz * sz
            t = 0.0
            if length2 > 0.0:
                t = ((pb[0] - hp0[h, 0]) * sx + (pb[1] - hp0[h, 1]) * sy + (pb[2] - hp0[h, 2]) * sz) / length2
                t = min(max(t, 0.0), 1.0)
            closing = 0.0
            for r in range(3):
                closing += u[r] * (hv0[h, r] + t * (hv1[h, r] - hv0[h, r]))
            m = write_point_row(out, m, d - real[0], u, pa, c, -closing, con, h, kin, scratch)
    return m


@numba.njit(cache=True)
def closest_axis_pair(p0, p1, radius, skip, hp0, hp1, hr):  # pragma: no cover - compiled
    """The closest robot-human pair (robot capsules from ``skip`` on): ``(distance [m], robot
    capsule, human capsule, robot axis point, human axis point)`` (-1 and NaN points without
    a human)."""
    best, capsule, person = np.inf, -1, -1
    pr, ph = np.full(3, np.nan), np.full(3, np.nan)
    ds, pa, pb = all_pairs(p0, p1, radius, skip, hp0, hp1, hr)
    n, k = ds.shape
    for i in range(n):
        for h in range(k):
            if ds[i, h] < best:
                best, capsule, person = ds[i, h], skip + i, h
                for r in range(3):
                    pr[r], ph[r] = pa[i, h, r], pb[i, h, r]
    return best, capsule, person, pr, ph


@numba.njit(cache=True)
def closest_of_rows(before, skip, p0, p1, radius, hp0, hp1, hr):  # pragma: no cover - compiled
    """``closest_axis_pair``'s result from the distances ``rows`` wrote at the same
    configuration (``before``: each pair's ``distance - critical``, robot-major): only the pairs
    with the least of them are measured again (subtracting the critical distance can round
    distances together), and the first with the least distance is the pair
    ``closest_axis_pair`` finds, without measuring every pair a second time."""
    k = hr.shape[0]
    least = np.inf
    for i in range(before.shape[0]):
        if before[i] < least:
            least = before[i]
    best, capsule, person = np.inf, -1, -1
    pr, ph = np.full(3, np.nan), np.full(3, np.nan)
    pa, pb = np.empty(3), np.empty(3)
    for i in range(before.shape[0]):
        if before[i] == least:
            c, h = skip + i // k, i % k
            d = capsule_pair(p0[c], p1[c], radius[c], hp0[h], hp1[h], hr[h], pa, pb)
            if d < best:
                best, capsule, person = d, c, h
                for r in range(3):
                    pr[r], ph[r] = pa[r], pb[r]
    return best, capsule, person, pr, ph


@numba.njit(cache=True)
def closest_pair(skip, kin, human, out_robot, out_human):  # pragma: no cover - compiled
    """The smallest robot-human capsule distance [m] (inf without a human) and its witness
    points on the two capsules' surfaces into ``out_robot``, ``out_human`` (3,) (NaN without)."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    hp0, hp1, hr, hv0, hv1 = human
    best, c, h, pa, pb = closest_axis_pair(p0, p1, radius, skip, hp0, hp1, hr)
    out_robot[:] = np.nan
    out_human[:] = np.nan
    if c >= 0:
        gx, gy, gz = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
        norm = np.sqrt(gx * gx + gy * gy + gz * gz)
        ux, uy, uz = (gx / norm, gy / norm, gz / norm) if norm > 1e-12 else (0.0, 0.0, 0.0)
        out_robot[0], out_robot[1], out_robot[2] = pa[0] + ux * radius[c], pa[1] + uy * radius[c], pa[2] + uz * radius[c]
        out_human[0], out_human[1], out_human[2] = pb[0] - ux * hr[h], pb[1] - uy * hr[h], pb[2] - uz * hr[h]
    return best
