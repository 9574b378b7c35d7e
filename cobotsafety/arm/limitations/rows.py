"""The compiled dispatch from a limitation's kind code to its module's functions.

``kin`` is the robot's kinematics at the state the rows are taken at, one tuple:
``(q (nq,), p_ee (3,), J6 (6, nv), oR (nj, 3, 3), op (nj, 3), p0 (c, 3), p1 (c, 3), radius (c,),
cap_joint (c,), axes (nj, 3), idx_v (nj,), support (nj, nj), lower (nq,), upper (nq,),
limited (L, 2), qdot (nv,))``, ``qdot`` the joint velocity the arm moves with into the step;
``human`` is ``(p0 (h, 3), p1 (h, 3), radius (h,), v0 (h, 3), v1 (h, 3))``; ``out`` is
``(dist (M,), A (M, nv), rate (M,), angular (M,), tag (M, 3), pull (M,), drift (M,))``, filled
from row ``m``; ``pull`` and ``drift`` [m/s^2] (zero unless the kind writes them) are how fast the
arm, moving at ``qdot`` with no acceleration of its own, approaches the limitation along the row:
``pull`` by the limitation's curvature (the reach's: outward, toward the extended sphere and away
from the inner one), ``drift`` by the row's point's own motion (``kinematics.drift_along``: a
turning link carries its points on a curve, toward a limitation as often as away from it).
"""

from __future__ import annotations

import numba

from cobotsafety.arm.limitations import box_zone, capsule_zone, halfspace_zone, human, joint_range, reach, table


@numba.njit(cache=True)
def kind_count(kind, real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    """How many distances the limitation has (its share of the safety net's checks); -1 for
    an unknown kind."""
    if kind == joint_range.KIND:
        return joint_range.count(real, skip, n_caps, n_limited, n_human)
    if kind == reach.KIND:
        return reach.count(real, skip, n_caps, n_limited, n_human)
    if kind == table.KIND:
        return table.count(real, skip, n_caps, n_limited, n_human)
    if kind == capsule_zone.KIND:
        return capsule_zone.count(real, skip, n_caps, n_limited, n_human)
    if kind == halfspace_zone.KIND:
        return halfspace_zone.count(real, skip, n_caps, n_limited, n_human)
    if kind == box_zone.KIND:
        return box_zone.count(real, skip, n_caps, n_limited, n_human)
    if kind == human.KIND:
        return human.count(real, skip, n_caps, n_limited, n_human)
    return -1


@numba.njit(cache=True, inline="always")
def kind_rows(kind, real, skip, con, kin, hum, activation_m, out, m, before):  # pragma: no cover - compiled
    """Append limitation ``con``'s active rows from row ``m`` (its distances into ``before``);
    the new row count."""
    if kind == joint_range.KIND:
        return joint_range.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == reach.KIND:
        return reach.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == table.KIND:
        return table.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == capsule_zone.KIND:
        return capsule_zone.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == halfspace_zone.KIND:
        return halfspace_zone.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == box_zone.KIND:
        return box_zone.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    if kind == human.KIND:
        return human.rows(real, skip, con, kin, hum, activation_m, out, m, before)
    return -1


@numba.njit(cache=True, inline="always")
def kind_distances(kind, real, skip, kin, hum, out):  # pragma: no cover - compiled
    """The limitation's distances (the safety net's check) into ``out``."""
    if kind == joint_range.KIND:
        joint_range.distances(real, skip, kin, hum, out)
    elif kind == reach.KIND:
        reach.distances(real, skip, kin, hum, out)
    elif kind == table.KIND:
        table.distances(real, skip, kin, hum, out)
    elif kind == capsule_zone.KIND:
        capsule_zone.distances(real, skip, kin, hum, out)
    elif kind == halfspace_zone.KIND:
        halfspace_zone.distances(real, skip, kin, hum, out)
    elif kind == box_zone.KIND:
        box_zone.distances(real, skip, kin, hum, out)
    elif kind == human.KIND:
        human.distances(real, skip, kin, hum, out)
