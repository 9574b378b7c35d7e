"""Exact 2D projection onto half-planes, in plain floats (the planar step's hot path).

Same problem as ``cobotsafety.slide`` (tested to agree with it): the point closest to
``(vx, vy)`` with ``nx * x + ny * y >= bound`` for every row. In 2D the optimum is the desired
point itself, its projection onto one violated line, or the intersection of two lines; the
feasible candidate nearest to the desired point is the optimum, because every candidate that is
feasible is at least as far as the optimum and the optimum is among them.
"""

from __future__ import annotations

import math

_TOL = 1e-12


def _feasible(x: float, y: float, rows: list) -> bool:
    for nx, ny, bound, _ in rows:
        if nx * x + ny * y < bound - 1e-10:
            return False
    return True


def project_2d(vx: float, vy: float, rows: list) -> tuple[float, float, bool]:
    """Return ``(x, y, ok)``; rows are ``(nx, ny, bound, name)`` with unit normals.

    ``ok`` is False when the rows contradict each other (the caller commands zero).
    """
    violated = [r for r in rows if r[0] * vx + r[1] * vy < r[2] - _TOL]
    if not violated:
        return vx, vy, True
    best = None
    best_d2 = math.inf
    for nx, ny, bound, _ in violated:
        s = bound - (nx * vx + ny * vy)
        x, y = vx + s * nx, vy + s * ny
        d2 = s * s
        if d2 < best_d2 and _feasible(x, y, rows):
            best, best_d2 = (x, y), d2
    if best is not None:
        return best[0], best[1], True
    for i, (n1x, n1y, b1, _) in enumerate(violated):
        for n2x, n2y, b2, _ in rows:
            det = n1x * n2y - n1y * n2x
            if abs(det) < 1e-12:
                continue
            x = (b1 * n2y - n1y * b2) / det
            y = (n1x * b2 - b1 * n2x) / det
            d2 = (x - vx) ** 2 + (y - vy) ** 2
            if d2 < best_d2 and _feasible(x, y, rows):
                best, best_d2 = (x, y), d2
    if best is None:
        return 0.0, 0.0, False
    return best[0], best[1], True
