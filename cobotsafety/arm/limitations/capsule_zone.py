"""Capsule and sphere protection zones: every robot capsule stays out of them.

Rows (metres): the capsule-capsule clearance of each robot capsule from ``skip_capsules`` on
(``cobotsafety.geometry.capsule.capsule_pair``), gradient ``u . J_p`` at the robot capsule's
closest axis point ``p``, ``u`` the unit vector from the zone's closest point (paper 1, II.G:
``J_c`` of the closest point); and the same at each end of the robot's segment (the end's own
clearance), as the box zone has. A link swinging past the zone carries its closest point along
its axis (on the iiwa's wrist, at ~0.4 m/s: the distance then closes ~0.9 m/s^2 faster than the
closest point's own motion says, the envelope of a minimum), to an end; the end arriving has
been braked by its own row, where the closest point's row alone met it at full speed (a
held-out hand drag gave up smoothness there). An end's row is left out while it is the closest
point (the same row twice). ``before``: three distances per capsule (the closest point's, then
the ends'). A sphere is a capsule of zero length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import direction_from, write_point_row
from cobotsafety.geometry.capsule import capsule_pair

KIND = 3
ANGULAR = False


@dataclass(frozen=True)
class CapsuleZone:
    """A capsule-shaped zone: the segment ``p0``-``p1`` [m] (base frame) swept by ``radius_m``."""

    name: str
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    radius_m: float
    skip_capsules: int = 1
    """The first capsules (the fixed base) are not checked."""


@dataclass(frozen=True)
class SphereZone:
    """A spherical zone of ``radius_m`` around ``center`` [m] (base frame)."""

    name: str
    center: tuple[float, float, float]
    radius_m: float
    skip_capsules: int = 1


def pack(zone: CapsuleZone | SphereZone, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    if isinstance(zone, SphereZone):
        real[0:3], real[3:6] = zone.center, zone.center
    else:
        real[0:3], real[3:6] = zone.p0, zone.p1
    real[6] = zone.radius_m
    return real, zone.skip_capsules


def row_name(zone, robot, a: int, b: int) -> str:
    return f"{zone.name} ({robot.capsules[a].name})"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 3 * max(n_caps - skip, 0)


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pa, pb = np.empty(3), np.empty(3)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        out[3 * i] = capsule_pair(p0[c], p1[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)
        out[3 * i + 1] = capsule_pair(p0[c], p0[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)
        out[3 * i + 2] = capsule_pair(p1[c], p1[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)


@numba.njit(cache=True, inline="always")
def _same_point(a, b):  # pragma: no cover - compiled
    """Whether ``a`` and ``b`` are one point (to 1e-9 m: the closest point ``a + s (b - a)``
    of a segment at ``s = 1`` rounds)."""
    return abs(a[0] - b[0]) <= 1e-9 and abs(a[1] - b[1]) <= 1e-9 and abs(a[2] - b[2]) <= 1e-9


@numba.njit(cache=True, inline="always")
def _write(out, m, value, pa, pb, c, con, b, kin, scratch, u):  # pragma: no cover - compiled
    """Row ``m`` at ``pa`` for the distance ``value`` from the zone's point ``pb``."""
    direction_from(pb, pa, 1e-12, u)
    return write_point_row(out, m, value, u, pa, c, 0.0, con, b, kin, scratch)


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pa, pb, u = np.empty(3), np.empty(3), np.empty(3)
    pe, pz = np.empty(3), np.empty(3)
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        value = capsule_pair(p0[c], p1[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)
        before[3 * i] = value
        if value < activation_m:
            m = _write(out, m, value, pa, pb, c, con, 0, kin, scratch, u)
        for end in range(2):
            point = p0[c] if end == 0 else p1[c]
            value_end = capsule_pair(point, point, radius[c], real[0:3], real[3:6], real[6], pe, pz)
            before[3 * i + 1 + end] = value_end
            if value_end >= activation_m or (value < activation_m and _same_point(point, pa)):
                continue
            m = _write(out, m, value_end, pe, pz, c, con, 1 + end, kin, scratch, u)
    return m
