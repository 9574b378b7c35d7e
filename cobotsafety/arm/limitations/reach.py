"""Reach limits: the end-effector stays between ``inner_m`` and ``outer_m`` from a shoulder point.

Rows (metres of the end-effector): ``r - inner`` and ``outer - r`` with ``r`` its distance from
the shoulder; gradient ``+-u . J_ee`` (``u`` the unit vector from the shoulder).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.kinematics import drift_along
from cobotsafety.small_linalg import matvec

KIND = 1
ANGULAR = False


@dataclass(frozen=True)
class ReachLimits:
    """Inner and extended reach [m] around ``shoulder`` (base frame) [m]."""

    shoulder: tuple[float, float, float]
    inner_m: float
    outer_m: float
    name: str = "reach"


def pack(limitation: ReachLimits, robot) -> tuple[np.ndarray, int]:
    real = np.zeros(12)
    real[0:3], real[3], real[4] = limitation.shoulder, limitation.inner_m, limitation.outer_m
    return real, 0


def row_name(limitation: ReachLimits, robot, a: int, b: int) -> str:
    return f"{limitation.name} {('inner', 'extended')[a]}"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 2


@numba.njit(cache=True)
def _radius(real, p_ee):  # pragma: no cover - compiled
    ox, oy, oz = p_ee[0] - real[0], p_ee[1] - real[1], p_ee[2] - real[2]
    return np.sqrt(ox * ox + oy * oy + oz * oz), ox, oy, oz


@numba.njit(cache=True)
def outward_drift(real, p_ee, v):  # pragma: no cover - compiled
    """How fast [m/s^2] a hand moving at ``v`` [m/s] with no acceleration of its own approaches
    the extended reach: ``r'' = u . a + |v_t|^2 / r`` (``v_t`` its velocity across the radius
    ``u``), so ``|v_t|^2 / r`` at ``a = 0``. The one concave limitation: a hand sliding along the
    sphere drifts outward and must be pulled in; every other surface is a plane or bulges
    toward the arm (its curvature helps a brake)."""
    r, ox, oy, oz = _radius(real, p_ee)
    if r <= 1e-12:
        return 0.0
    radial = (ox * v[0] + oy * v[1] + oz * v[2]) / r
    across2 = max(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - radial * radial, 0.0)
    return across2 / r


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    r, _, _, _ = _radius(real, p_ee)
    out[0], out[1] = r - real[3], real[4] - r


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    dist, A, rate, angular, tag, pull, drift = out
    r, ox, oy, oz = _radius(real, p_ee)
    if r > 1e-12:
        ux, uy, uz = ox / r, oy / r, oz / r
    else:
        ux, uy, uz = 0.0, 0.0, 1.0
    for side in range(2):
        value = r - real[3] if side == 0 else real[4] - r
        before[side] = value
        if value >= activation_m:
            continue
        sign = 1.0 if side == 0 else -1.0
        dist[m] = value
        for col in range(A.shape[1]):
            A[m, col] = sign * (ux * J6[0, col] + uy * J6[1, col] + uz * J6[2, col])
        rate[m], angular[m] = 0.0, False
        drift[m] = -drift_along(np.array([sign * ux, sign * uy, sign * uz]), J6, qdot)
        # The sphere's curvature: a hand sliding along it at v_t drifts outward (|v_t|^2 / r),
        # toward the extended reach and away from the inner one. (Its own drift, ``drift``, holds
        # a hand gliding round the shoulder to the sphere: the two cancel there.)
        pull[m] = sign * -outward_drift(real, p_ee, matvec(J6[:3], qdot))
        tag[m, 0], tag[m, 1], tag[m, 2] = con, side, 0
        m += 1
    return m
