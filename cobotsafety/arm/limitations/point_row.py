"""One metric row through a point of the arm: the row every point-based kind writes.

A limitation seen from a point ``p`` fixed to a robot capsule's link (or the hand): its
distance ``value`` [m], the row ``u . J_p`` (``u`` the direction in which moving ``p`` increases
the distance), the distance's own rate (a moving person's), and ``drift``, how fast the point
approaches along ``-u`` when the arm coasts at its velocity now (``kinematics.drift_along``).
Both from one ``frame_jacobian`` at ``p``.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.kinematics import drift_along, frame_jacobian


@numba.njit(cache=True, inline="always")
def direction_from(pb, pa, tiny, u):  # pragma: no cover - compiled
    """``u`` (3,) written: the unit vector from ``pb`` to ``pa`` (the direction in which moving
    ``pa`` away from ``pb`` increases their distance), or ``+z`` when they are within ``tiny``
    [m] of each other (no direction)."""
    gx, gy, gz = pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]
    norm = np.sqrt(gx * gx + gy * gy + gz * gz)
    if norm > tiny:
        u[0], u[1], u[2] = gx / norm, gy / norm, gz / norm
    else:
        u[0], u[1], u[2] = 0.0, 0.0, 1.0


@numba.njit(cache=True, inline="always")
def write_point_row(out, m, value, u, p, c, own_rate, con, b, kin, scratch):  # pragma: no cover - compiled
    """Row ``m`` of ``out`` (``limitations/rows.py``'s tuple) for the point ``p`` of capsule
    ``c``, tagged ``(con, c, b)``; ``scratch`` (6, nv) is written. Returns ``m + 1``."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    dist, A, rate, angular, tag, pull, drift = out
    dist[m] = value
    frame_jacobian(p, cap_joint[c], oR, op, axes, idx_v, support, scratch)
    for k in range(A.shape[1]):
        A[m, k] = u[0] * scratch[0, k] + u[1] * scratch[1, k] + u[2] * scratch[2, k]
    drift[m] = -drift_along(u, scratch, qdot)
    rate[m], angular[m] = own_rate, False
    tag[m, 0], tag[m, 1], tag[m, 2] = con, c, b
    return m + 1
