"""The trial course (paper 1, Fig. 6): circles to reach in order, triangles not to touch."""

from __future__ import annotations

import math
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
    start_m: tuple[float, float] | None = None
    """Where the robot waits at the start [m] (the robot's home), for checks on the first route."""

    def routes_m(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The straight routes (from, to) [m] between consecutive targets, from the start."""
        points = ([self.start_m] if self.start_m is not None else []) + list(self.targets_m)
        return [(np.asarray(a, dtype=float), np.asarray(b, dtype=float)) for a, b in zip(points, points[1:])]

    def route_clearance_m(self, samples: int = 400) -> float:
        """Smallest distance from any straight route to any triangle [m] (0 = a route crosses one)."""
        best = np.inf
        for a, b in self.routes_m():
            for s in np.linspace(0.0, 1.0, samples):
                p = a + s * (b - a)
                for tri in self.obstacles_m:
                    best = min(best, _point_triangle_distance(p, np.asarray(tri)))
        return float(best)

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
    """0 inside the triangle, else the distance to its boundary [m] (plain floats: this runs
    every simulated step)."""
    px, py = float(p[0]), float(p[1])
    corners = [(float(tri[k][0]), float(tri[k][1])) for k in range(3)]
    best = math.inf
    positive = negative = False
    for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1]):
        ex, ey = bx - ax, by - ay
        cross = ex * (py - ay) - ey * (px - ax)
        positive |= cross > 0.0
        negative |= cross < 0.0
        t = min(max(((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
        best = min(best, math.hypot(px - ax - t * ex, py - ay - t * ey))
    return 0.0 if not (positive and negative) else best


def planar_course() -> Course:
    """A Fig. 6-like course in the planar arm's workspace (start (-0.2, 0.03) m), driven in the
    trial scene (``planar_scenes.trial_scene``: limitations A-E, no protection zones).

    Like paper 1's course, it makes the participant meet the workspace limits. Driven straight
    under sliding (``trial_scene.straight_drive``, tested): the route start -> 1 slides on
    joint 2's circle B, 2 -> 3 on joint 1's lower limit D, 3 -> 4 on circle B again: three
    binding episodes, the other three routes are free. Targets 2, 5 and 6 lie 2-6 cm inside
    the extended reach E (a straight route between two points inside a circle never meets it,
    an overshoot does). The two triangles sit 4-5 cm beside the straight routes 1 -> 2 and
    5 -> 6: obstacles to steer around, never on the straight path (tested).
    """
    return Course(
        "planar",
        ((0.35, 0.25), (0.55, 0.0), (0.10, 0.19), (-0.45, 0.0), (-0.25, 0.48), (0.10, 0.50)),
        0.03,
        (((0.47, 0.17), (0.53, 0.17), (0.50, 0.22)), ((-0.11, 0.40), (-0.05, 0.40), (-0.08, 0.445))),
        start_m=(-0.2, 0.03),
    )


def arm_course(height_m: float = 0.30) -> Course:
    """The same kind of course for a 3D arm, in the horizontal plane ``z = height_m``; the
    triangles sit 5 cm or more beside the straight routes (not reworked for the arm's limits)."""
    return Course(
        "arm",
        ((0.45, -0.30), (0.60, 0.0), (0.45, 0.30), (0.30, 0.10), (0.35, -0.15)),
        0.03,
        (((0.60, -0.24), (0.66, -0.18), (0.58, -0.16)), ((0.58, 0.16), (0.64, 0.22), (0.56, 0.24))),
        height_m,
    )
