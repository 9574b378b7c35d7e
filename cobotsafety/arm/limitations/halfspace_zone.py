"""A half-space zone (a wall): everything on the side ``normal`` points to from ``point`` is
forbidden.

Rows (metres): for each robot capsule, both end points' clearance ``-s - r`` (``s`` the end
point's signed height over the plane, ``r`` the capsule's radius), gradient ``-n . J_p`` at that
end point. The capsule's clearance is the smaller of the two; keeping both as rows keeps each
smooth (the smaller one switches ends as the capsule tilts: its gradient would jump).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import write_point_row

KIND = 4
ANGULAR = False


@dataclass(frozen=True)
class HalfSpaceZone:
    """The forbidden side of the plane through ``point`` [m] with outward ``normal`` (base frame)."""

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    skip_capsules: int = 1


def pack(zone: HalfSpaceZone, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    n = np.asarray(zone.normal, dtype=float)
    real[0:3], real[3:6] = zone.point, n / np.linalg.norm(n)
    return real, zone.skip_capsules


def row_name(zone: HalfSpaceZone, robot, a: int, b: int) -> str:
    return f"{zone.name} ({robot.capsules[a].name})"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 2 * max(n_caps - skip, 0)


@numba.njit(cache=True)
def _heights(real, p0, p1, c):  # pragma: no cover - compiled
    s0 = (p0[c, 0] - real[0]) * real[3] + (p0[c, 1] - real[1]) * real[4] + (p0[c, 2] - real[2]) * real[5]
    s1 = (p1[c, 0] - real[0]) * real[3] + (p1[c, 1] - real[1]) * real[4] + (p1[c, 2] - real[2]) * real[5]
    return s0, s1


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    for i in range(p0.shape[0] - skip):
        s0, s1 = _heights(real, p0, p1, skip + i)
        out[2 * i], out[2 * i + 1] = -s0 - radius[skip + i], -s1 - radius[skip + i]


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    away = -real[3:6]
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        s0, s1 = _heights(real, p0, p1, c)
        for end in range(2):
            value = -(s0 if end == 0 else s1) - radius[c]
            before[2 * i + end] = value
            if value >= activation_m:
                continue
            m = write_point_row(out, m, value, away, p0[c] if end == 0 else p1[c], c, 0.0, con, end, kin, scratch)
    return m
