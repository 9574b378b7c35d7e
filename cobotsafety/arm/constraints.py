"""Limitations of a 3D arm as joint-space measures; ``step`` maps them onto the command.

Every constraint returns ``Measures``: signed distances ``d`` (m,) [m or rad], their joint-space
gradients ``A`` (m, nv) (``d_dot = A @ qdot``), names, and whether each is angular. The step
turns them into half-spaces on the Cartesian command through ``qdot = M v + c`` (the
pseudo-inverse mapping and its null-space term): normal ``M^T a``, bound
``approach_bound(d, ...) - a @ c``. This is paper 1's eq. 8 (``J_c J^-1``) for any point, with
``J^+`` for redundant arms.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from cobotsafety.arm.robot_state import RobotState
from cobotsafety.geometry.capsule import capsule_distance


class Measures(NamedTuple):
    distance: np.ndarray
    A: np.ndarray
    names: tuple[str, ...]
    angular: np.ndarray
    rate: np.ndarray | None = None
    """Shape (m,): how fast each distance changes by itself [m/s] (a moving human), so that
    ``d_dot = A @ qdot + rate``; None means zeros."""

    @staticmethod
    def empty(nv: int) -> "Measures":
        return Measures(np.zeros(0), np.zeros((0, nv)), (), np.zeros(0, dtype=bool))

    @staticmethod
    def stack(parts: Sequence["Measures"], nv: int) -> "Measures":
        parts = [p for p in parts if p.distance.size]
        if not parts:
            return Measures.empty(nv)
        rate = None
        if any(p.rate is not None for p in parts):
            rate = np.concatenate([p.rate if p.rate is not None else np.zeros(p.distance.size) for p in parts])
        return Measures(np.concatenate([p.distance for p in parts]), np.vstack([p.A for p in parts]),
                        tuple(n for p in parts for n in p.names), np.concatenate([p.angular for p in parts]), rate)


class ArmConstraint:
    """Base class: ``measures(state, activation_m)`` returns the limitation's measures.

    ``distances`` are in metres of a point of the robot (1-Lipschitz in that point's position)
    unless ``angular`` (radians of a joint); the safety net uses this to skip limits that a
    step is too short to reach.
    """

    name: str
    angular = False

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        raise NotImplementedError

    def distances(self, state: RobotState) -> np.ndarray:
        return self.measures(state).distance

    def measures_and_distances(self, state: RobotState, activation_m: float) -> tuple[Measures, np.ndarray]:
        """Both at once; constraints whose geometry is costly override it to compute it once."""
        return self.measures(state, activation_m), self.distances(state)


@dataclass(frozen=True)
class JointPositionLimits(ArmConstraint):
    """Every joint with finite limits stays within them (row i of ``M``: joint i's rate)."""

    name: str = "joint"
    angular = True

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        pairs = state.limited_v
        if pairs.size == 0:
            return Measures.empty(state.nv)
        iq, iv = pairs[:, 0], pairs[:, 1]
        q = state.q[iq]
        k = len(iq)
        A = np.zeros((2 * k, state.nv))
        A[np.arange(k), iv] = 1.0
        A[k + np.arange(k), iv] = -1.0
        d = np.concatenate([q - state.lower[iq], state.upper[iq] - q])
        names = tuple(f"{joint} {side}" for side in ("lower", "upper") for joint in state.limited_names)
        return Measures(d, A, names, np.ones(2 * k, dtype=bool))

    def distances(self, state: RobotState) -> np.ndarray:
        iq = state.limited_v[:, 0]
        q = state.q[iq]
        return np.concatenate([q - state.lower[iq], state.upper[iq] - q])


@dataclass(frozen=True)
class ReachLimits(ArmConstraint):
    """The end-effector stays between ``inner_m`` and ``outer_m`` from the shoulder point."""

    shoulder: tuple[float, float, float]
    inner_m: float
    outer_m: float
    name: str = "reach"

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        offset = state.p_world_ee - np.asarray(self.shoulder)
        r = float(np.linalg.norm(offset))
        u = offset / r if r > 1e-12 else np.array([0.0, 0.0, 1.0])
        radial = u @ state.J_ee
        return Measures(np.array([r - self.inner_m, self.outer_m - r]), np.vstack([radial, -radial]),
                        (f"{self.name} inner", f"{self.name} extended"), np.zeros(2, dtype=bool))


@dataclass(frozen=True)
class TablePlane(ArmConstraint):
    """No robot capsule goes below the plane ``z = height_m`` (table or floor)."""

    height_m: float = 0.0
    name: str = "table"
    skip_capsules: int = 1
    """The first capsules sit on the base and cannot reach the table: not checked."""

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        p0, p1 = state.capsule_p0[self.skip_capsules:], state.capsule_p1[self.skip_capsules:]
        low = np.where((p0[:, 2] <= p1[:, 2])[:, None], p0, p1)
        d = low[:, 2] - state.capsule_radius[self.skip_capsules:] - self.height_m
        keep = np.flatnonzero(d < activation_m)
        A = np.array([state.point_jacobian(self.skip_capsules + i, low[i])[2] for i in keep]).reshape(-1, state.nv)
        names = tuple(f"{self.name} ({state.capsules[self.skip_capsules + i].name})" for i in keep)
        return Measures(d[keep], A, names, np.zeros(len(keep), dtype=bool))

    def distances(self, state: RobotState) -> np.ndarray:
        p0, p1 = state.capsule_p0[self.skip_capsules:], state.capsule_p1[self.skip_capsules:]
        return np.minimum(p0[:, 2], p1[:, 2]) - state.capsule_radius[self.skip_capsules:] - self.height_m


@dataclass(frozen=True)
class ZoneConstraint(ArmConstraint):
    """Every robot capsule stays out of ``zone`` (box, sphere, capsule or half-space), through
    the Jacobian of the capsule's point closest to the zone (paper 1, section II.G).

    Zones with a ``bounding_sphere()`` (the box, whose exact distance is the costliest) are
    first tested against that sphere: a capsule whose distance to the sphere is at least the
    activation distance (``measures``) or positive (``distances``) gets that lower bound as its
    distance, which decides the same (inactive; not crossed) at a fraction of the cost.
    """

    zone: object
    skip_capsules: int = 0

    @property
    def name(self) -> str:
        return self.zone.name

    def _geometry(self, state: RobotState, exact_below_m: float):
        """Distances (c,) [m], exact where below ``exact_below_m``, else a lower bound; the
        indices computed exactly, their closest points (k, 3) and clearance directions (k, 3)."""
        s = self.skip_capsules
        p0, p1, radius = state.capsule_p0[s:], state.capsule_p1[s:], state.capsule_radius[s:]
        bounding = getattr(self.zone, "bounding_sphere", None)
        if bounding is None:
            d, p_robot, u = self.zone.capsule_distances(p0, p1, radius)
            return d, np.arange(len(d)), p_robot, u
        centre, sphere_radius = bounding()
        centres = np.broadcast_to(centre, p0.shape)  # same shapes: capsule_distance's no-broadcast path
        d, _, _ = capsule_distance(p0, p1, radius, centres, centres, np.full(len(radius), sphere_radius))
        near = np.flatnonzero(d < exact_below_m)
        if near.size == 0:
            return d, near, np.zeros((0, 3)), np.zeros((0, 3))
        d_near, p_robot, u = self.zone.capsule_distances(p0[near], p1[near], radius[near])
        d[near] = d_near
        return d, near, p_robot, u

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        return self.measures_and_distances(state, activation_m)[0]

    def measures_and_distances(self, state: RobotState, activation_m: float) -> tuple[Measures, np.ndarray]:
        s = self.skip_capsules
        d, near, p_robot, u = self._geometry(state, activation_m)
        keep = np.flatnonzero(d[near] < activation_m)  # positions within ``near``
        A = np.array([u[k] @ state.point_jacobian(s + near[k], p_robot[k]) for k in keep]).reshape(-1, state.nv)
        names = tuple(f"{self.zone.name} ({state.capsules[s + near[k]].name})" for k in keep)
        return Measures(d[near[keep]], A, names, np.zeros(len(keep), dtype=bool)), d

    def distances(self, state: RobotState) -> np.ndarray:
        return self._geometry(state, 0.0)[0]
