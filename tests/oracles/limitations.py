"""Each limitation kind's rows written plainly: numpy geometry and pinocchio's point Jacobians.

A row is ``Row(d, a, rate, angular, tag)``: the signed distance ``d`` [m or rad] (positive where
allowed), its joint-space gradient ``a`` (nv,) (``d_dot = a @ qdot + rate``), the rate at which
``d`` changes by itself (a moving human) [m/s], whether ``d`` is an angle, and the tag the
compiled step gives it: ``(limitation index, a, b)``. ``rows`` returns the rows within the
activation distance and every distance the kind measures (in the compiled order);
``distances`` what the safety net re-checks after a step. The specification is each kind's
module docstring (``cobotsafety/arm/limitations/``); the geometry is the old reference step's
(``arm/zones.py``, ``arm/constraints.py``, ``control/human_constraint.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from cobotsafety.arm.limitations import (BoxZone, CapsuleZone, HalfSpaceZone, HumanLimitation, JointPositionLimits,
                                         ReachLimits, SphereZone, TablePlane)
from .geometry import capsule_pair, segment_box, unit
from .kinematics import Kinematics

UP = np.array([0.0, 0.0, 1.0])


class Row(NamedTuple):
    d: float
    a: np.ndarray
    rate: float
    angular: bool
    tag: tuple[int, int, int]
    point: np.ndarray | None = None
    """A metric row's point [m] (fixed to its capsule's link, or the hand) ..."""
    normal: np.ndarray | None = None
    """... and the direction in which moving it increases ``d`` (``a = normal . J_point``)."""


@dataclass(frozen=True)
class Human:
    """The human's capsules (h, 3), (h, 3), (h,) [m] and end-point velocities (h, 3) [m/s],
    already moved to the step's time."""

    p0: np.ndarray
    p1: np.ndarray
    radius: np.ndarray
    v0: np.ndarray
    v1: np.ndarray

    @classmethod
    def none(cls) -> "Human":
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)))

    def ahead(self, ahead_s: float) -> "Human":
        """The capsules moved ``ahead_s`` [s] along their velocities."""
        return Human(self.p0 + ahead_s * self.v0, self.p1 + ahead_s * self.v1, self.radius, self.v0, self.v1)


def _capsules(kin: Kinematics, skip: int) -> range:
    return range(skip, len(kin.radius))


# ---- one function per kind: (rows, distances measured) -----------------------------------------

def joint_rows(lim: JointPositionLimits, con: int, kin: Kinematics, human: Human, activation_m: float):
    robot = kin.robot
    rows, measured = [], []
    for side in (0, 1):
        for i, (iq, iv) in enumerate(robot.limited):
            d = kin.q[iq] - robot.lower[iq] if side == 0 else robot.upper[iq] - kin.q[iq]
            a = np.zeros(robot.nv)
            a[iv] = 1.0 if side == 0 else -1.0
            measured.append(d)
            rows.append(Row(d, a, 0.0, True, (con, side, i)))  # always active
    return rows, measured


def reach_rows(lim: ReachLimits, con: int, kin: Kinematics, human: Human, activation_m: float):
    offset = kin.p_ee - np.asarray(lim.shoulder, dtype=float)
    r = float(np.linalg.norm(offset))
    radial = unit(offset, UP) @ kin.J_ee
    rows, measured = [], []
    for side, (d, a) in enumerate(((r - lim.inner_m, radial), (lim.outer_m - r, -radial))):
        measured.append(d)
        if d < activation_m:
            rows.append(Row(d, a, 0.0, False, (con, side, 0), kin.p_ee, (1.0 - 2.0 * side) * unit(offset, UP)))
    return rows, measured


def table_rows(lim: TablePlane, con: int, kin: Kinematics, human: Human, activation_m: float):
    rows, measured = [], []
    for c in _capsules(kin, lim.skip_capsules):
        for end, p in enumerate((kin.p0[c], kin.p1[c])):
            d = p[2] - kin.radius[c] - lim.height_m
            measured.append(d)
            if d < activation_m:
                rows.append(Row(d, UP @ kin.capsule_jacobian(c, p), 0.0, False, (con, c, end), p, UP))
    return rows, measured


def halfspace_rows(lim: HalfSpaceZone, con: int, kin: Kinematics, human: Human, activation_m: float):
    n = np.asarray(lim.normal, dtype=float)
    n = n / np.linalg.norm(n)
    rows, measured = [], []
    for c in _capsules(kin, lim.skip_capsules):
        for end, p in enumerate((kin.p0[c], kin.p1[c])):
            d = -((p - np.asarray(lim.point, dtype=float)) @ n) - kin.radius[c]
            measured.append(d)
            if d < activation_m:
                rows.append(Row(d, -n @ kin.capsule_jacobian(c, p), 0.0, False, (con, c, end), p, -n))
    return rows, measured


def _zone_segment(lim):
    if isinstance(lim, SphereZone):
        return np.asarray(lim.center, dtype=float), np.asarray(lim.center, dtype=float)
    return np.asarray(lim.p0, dtype=float), np.asarray(lim.p1, dtype=float)


def capsule_zone_rows(lim, con: int, kin: Kinematics, human: Human, activation_m: float):
    """Per capsule: the closest point's row, then each end's (unless it is the closest point)."""
    z0, z1 = _zone_segment(lim)
    rows, measured = [], []
    for c in _capsules(kin, lim.skip_capsules):
        d, pa, pb = capsule_pair(kin.p0[c], kin.p1[c], kin.radius[c], z0, z1, lim.radius_m)
        measured.append(d)
        if d < activation_m:
            u = unit(pa - pb, UP)
            rows.append(Row(d, u @ kin.capsule_jacobian(c, pa), 0.0, False, (con, c, 0), pa, u))
        for end, e in enumerate((kin.p0[c], kin.p1[c])):
            d_end, _, pz = capsule_pair(e, e, kin.radius[c], z0, z1, lim.radius_m)
            measured.append(d_end)
            if d_end < activation_m and not (d < activation_m and np.allclose(e, pa, rtol=0, atol=1e-9)):
                u_end = unit(e - pz, UP)
                rows.append(Row(d_end, u_end @ kin.capsule_jacobian(c, e), 0.0, False, (con, c, 1 + end), e, u_end))
    return rows, measured


def box_clearance(lim: BoxZone, kin: Kinematics, c: int, exact_below_m: float):
    """A robot capsule's clearance to the box [m]: exact (with its closest point and direction)
    when the capsule is nearer than ``exact_below_m`` to the box's bounding sphere, else its
    distance to that sphere (a lower bound, cheaper)."""
    centre, sphere_radius = lim.bounding_sphere()
    bound, _, _ = capsule_pair(kin.p0[c], kin.p1[c], kin.radius[c], centre, centre, sphere_radius)
    if bound >= exact_below_m:
        return bound, None, None
    d, p, u = segment_box(kin.p0[c], kin.p1[c], np.asarray(lim.center, dtype=float),
                          np.asarray(lim.half_size, dtype=float))
    return d - kin.radius[c], p, u


def point_box(lim: BoxZone, p: np.ndarray) -> tuple[float, np.ndarray]:
    """The box's signed distance at the point ``p`` [m] and the unit direction that increases it
    (outside: from the box's nearest point; inside: the nearest face's normal)."""
    offset = p - np.asarray(lim.center, dtype=float)
    q = np.abs(offset) - np.asarray(lim.half_size, dtype=float)
    sign = np.where(offset >= 0.0, 1.0, -1.0)
    outside = np.maximum(q, 0.0)
    if np.linalg.norm(outside) > 0.0:
        return float(np.linalg.norm(outside)), sign * outside / np.linalg.norm(outside)
    k = int(np.argmax(q))
    return float(q[k]), sign * np.eye(3)[k]


def box_rows(lim: BoxZone, con: int, kin: Kinematics, human: Human, activation_m: float):
    """Per capsule: the closest point's row, then each end's (unless it is the closest point)."""
    rows, measured = [], []
    for c in _capsules(kin, lim.skip_capsules):
        d, p, u = box_clearance(lim, kin, c, activation_m)
        measured.append(d)
        if p is not None and d < activation_m:
            rows.append(Row(d, u @ kin.capsule_jacobian(c, p), 0.0, False, (con, c, 0), p, u))
        for end, e in enumerate((kin.p0[c], kin.p1[c])):
            d_end, u_end = point_box(lim, e)
            d_end -= kin.radius[c]
            measured.append(d_end)
            if d_end < activation_m and not (p is not None and np.allclose(e, p, rtol=0, atol=1e-9)):
                rows.append(Row(d_end, u_end @ kin.capsule_jacobian(c, e), 0.0, False, (con, c, 1 + end), e, u_end))
    return rows, measured


def human_rows(lim: HumanLimitation, con: int, kin: Kinematics, human: Human, activation_m: float):
    """Every (robot capsule, human capsule) pair within the limitation's own activation
    distance: ``distance - critical``, gradient ``u . J_p`` at the robot's closest axis point,
    rate ``-u . v_h`` with ``v_h`` interpolated at the human's closest axis point."""
    rows, measured = [], []
    for c in _capsules(kin, lim.skip_capsules):
        for h in range(len(human.radius)):
            d, pa, pb = capsule_pair(kin.p0[c], kin.p1[c], kin.radius[c], human.p0[h], human.p1[h], human.radius[h])
            measured.append(d - lim.critical_m)
            if d >= lim.activation_m:
                continue
            u = pa - pb
            u = u / np.linalg.norm(u) if np.linalg.norm(u) > 1e-9 else UP
            axis = human.p1[h] - human.p0[h]
            t = float(np.clip((pb - human.p0[h]) @ axis / (axis @ axis), 0.0, 1.0)) if axis @ axis > 0 else 0.0
            v_h = human.v0[h] + t * (human.v1[h] - human.v0[h])
            rows.append(Row(d - lim.critical_m, u @ kin.capsule_jacobian(c, pa), -(u @ v_h), False, (con, c, h), pa, u))
    return rows, measured


ROWS = {JointPositionLimits: joint_rows, ReachLimits: reach_rows, TablePlane: table_rows, HalfSpaceZone: halfspace_rows,
        CapsuleZone: capsule_zone_rows, SphereZone: capsule_zone_rows, BoxZone: box_rows, HumanLimitation: human_rows}


def rows(limitations, kin: Kinematics, human: Human, activation_m: float) -> tuple[list[Row], np.ndarray]:
    """The active rows of every limitation in order, and every distance measured (the
    compiled step's ``before``)."""
    found, measured = [], []
    for con, lim in enumerate(limitations):
        r, m = ROWS[type(lim)](lim, con, kin, human, activation_m)
        found += r
        measured += m
    return found, np.array(measured, dtype=float)


def distances(lim, kin: Kinematics, human: Human) -> np.ndarray:
    """What the safety net re-checks: every distance of the limitation, the box's exact only
    where the capsule touches its bounding sphere."""
    if isinstance(lim, BoxZone):
        return box_distances(lim, kin, 0.0)
    return np.array(ROWS[type(lim)](lim, 0, kin, human, -np.inf)[1], dtype=float)


def exact_distances(lim, kin: Kinematics, human: Human) -> np.ndarray:
    """Every distance of the limitation, exact (the box's too): the invariant's measure."""
    if isinstance(lim, BoxZone):
        return box_distances(lim, kin, np.inf)
    return distances(lim, kin, human)


def box_distances(lim: BoxZone, kin: Kinematics, exact_below_m: float) -> np.ndarray:
    """Per capsule: its clearance (``box_clearance``), then its ends' (always exact)."""
    out = []
    for c in _capsules(kin, lim.skip_capsules):
        out.append(box_clearance(lim, kin, c, exact_below_m)[0])
        out += [point_box(lim, e)[0] - kin.radius[c] for e in (kin.p0[c], kin.p1[c])]
    return np.array(out)
