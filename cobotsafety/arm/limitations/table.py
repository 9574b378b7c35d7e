"""The table (or floor): no robot capsule goes below the plane ``z = height_m``.

Rows (metres): for each capsule from ``skip_capsules`` on, both end points' height above the
plane minus the capsule's radius; gradient the z row of that end point's Jacobian (both ends
are rows: the lower one switches as the capsule tilts, and its gradient would jump).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import write_point_row

KIND = 2
ANGULAR = False


@dataclass(frozen=True)
class TablePlane:
    """The plane ``z = height_m`` [m]; the first ``skip_capsules`` sit on the base and are not checked."""

    height_m: float = 0.0
    name: str = "table"
    skip_capsules: int = 2


def pack(limitation: TablePlane, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    real[0] = limitation.height_m
    return real, limitation.skip_capsules


def row_name(limitation: TablePlane, robot, a: int, b: int) -> str:
    return f"{limitation.name} ({robot.capsules[a].name})"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 2 * max(n_caps - skip, 0)


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    for i in range(p0.shape[0] - skip):
        c = skip + i
        out[2 * i], out[2 * i + 1] = p0[c, 2] - radius[c] - real[0], p1[c, 2] - radius[c] - real[0]


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    up = np.array([0.0, 0.0, 1.0])
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        for end in range(2):
            point = p0[c] if end == 0 else p1[c]
            value = point[2] - radius[c] - real[0]
            before[2 * i + end] = value
            if value < activation_m:
                m = write_point_row(out, m, value, up, point, c, 0.0, con, end, kin, scratch)
    return m
