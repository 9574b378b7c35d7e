"""Capsule and sphere protection zones: every robot capsule stays out of them.

Rows (metres): the capsule-capsule clearance of each robot capsule from ``skip_capsules`` on
(``cobotsafety.geometry.capsule.capsule_pair``), gradient ``u . J_p`` at the robot capsule's
closest axis point ``p``, ``u`` the unit vector from the zone's closest point (paper 1, II.G:
``J_c`` of the closest point). A sphere is a capsule of zero length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.limitations.point_row import write_point_row
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
    return max(n_caps - skip, 0)


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pa, pb = np.empty(3), np.empty(3)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        out[i] = capsule_pair(p0[c], p1[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    pa, pb, u = np.empty(3), np.empty(3), np.empty(3)
    scratch = np.empty((6, out[1].shape[1]))  # (point_row's Jacobian)
    for i in range(p0.shape[0] - skip):
        c = skip + i
        value = capsule_pair(p0[c], p1[c], radius[c], real[0:3], real[3:6], real[6], pa, pb)
        before[i] = value
        if value >= activation_m:
            continue
        gx, gy, gz = pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]
        norm = np.sqrt(gx * gx + gy * gy + gz * gz)
        if norm > 1e-12:
            u[0], u[1], u[2] = gx / norm, gy / norm, gz / norm
        else:
            u[0], u[1], u[2] = 0.0, 0.0, 1.0
        m = write_point_row(out, m, value, u, pa, c, 0.0, con, 0, kin, scratch)
    return m
