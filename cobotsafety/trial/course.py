"""The trial course (paper 1, Fig. 6): circles to reach in order, triangles not to touch."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Course:
    """Targets [m] in order, their radius, and triangular obstacles (3 vertices each) [m].

    Positions are 2D (x, y) in the robot base frame; the 3D course puts them at ``height_m``.
    """

    name: str
    targets_m: tuple[tuple[float, float], ...]
    target_radius_m: float
    obstacles_m: tuple[tuple[tuple[float, float], ...], ...]
    height_m: float | None = None

    def reached(self, index: int, p_m: np.ndarray) -> bool:
        return float(np.linalg.norm(np.asarray(p_m)[:2] - self.targets_m[index])) <= self.target_radius_m

    def touched(self, p_m: np.ndarray, clearance_m: float = 0.0) -> int | None:
        """Index of the obstacle the end-effector touches (within ``clearance_m``), or None."""
        p = np.asarray(p_m, dtype=float)[:2]
        for i, tri in enumerate(self.obstacles_m):
            if _point_triangle_distance(p, np.asarray(tri)) <= clearance_m:
                return i
        return None


def _point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> float:
    """0 inside the triangle, else the distance to its boundary [m]."""
    signs = []
    best = np.inf
    for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
        e = b - a
        signs.append(e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0]))
        t = np.clip((p - a) @ e / (e @ e), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(p - (a + t * e))))
    if all(s >= 0 for s in signs) or all(s <= 0 for s in signs):
        return 0.0
    return best


def planar_course() -> Course:
    """A Fig. 6-like course in the planar arm's workspace: targets around the base close to the
    extended-reach circle (E, 0.57 m), with two triangles beside the straight routes."""
    return Course(
        "planar",
        ((-0.40, 0.15), (-0.30, 0.47), (0.05, 0.54), (0.33, 0.44), (0.50, 0.12)),
        0.03,
        (((-0.42, 0.30), (-0.36, 0.30), (-0.39, 0.36)), ((0.17, 0.44), (0.23, 0.44), (0.20, 0.50))),
    )


def arm_course(height_m: float = 0.30) -> Course:
    """The same kind of course for a 3D arm, in the horizontal plane ``z = height_m``."""
    return Course(
        "arm",
        ((0.45, -0.30), (0.60, 0.0), (0.45, 0.30), (0.30, 0.10), (0.35, -0.15)),
        0.03,
        (((0.52, -0.16), (0.58, -0.10), (0.50, -0.08)), ((0.50, 0.14), (0.56, 0.20), (0.48, 0.22))),
        height_m,
    )
