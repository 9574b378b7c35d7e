"""Small pure helpers shared by the scene views: polylines, capsule meshes, colours, quaternions.

Positions are in the robot base frame [m]; viser wants ``wxyz`` quaternions, the project API uses
``xyzw``: ``wxyz_from_xyzw`` converts at the scene boundary.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh

GREEN = (40, 180, 80)
AMBER = (240, 170, 20)
RED = (220, 40, 40)
GREY = (120, 120, 130)
HIGHLIGHT = (255, 60, 200)


def wxyz_from_xyzw(q_xyzw: np.ndarray) -> np.ndarray:
    """Shape (4,) scalar-last -> scalar-first."""
    q = np.asarray(q_xyzw, dtype=float)
    return np.array([q[3], q[0], q[1], q[2]])


def wxyz_z_to(direction: np.ndarray) -> np.ndarray:
    """Quaternion (wxyz) turning +z onto ``direction`` (shape (3,)); identity for a zero vector.

    Closed form (the half-way quaternion ``(1 + z.d, z x d)`` normalised); near -z, ``1 + dz`` is
    taken as ``(dx^2 + dy^2) / (1 - dz)`` (the same number on the unit sphere, without the
    cancellation), and exactly -z turns by pi about x. Called for every capsule in every frame,
    so no scipy call.
    """
    d = np.asarray(direction, dtype=float)
    length = float(np.linalg.norm(d))
    if length < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    dx, dy, dz = d / length
    w = 1.0 + dz if dz >= 0.0 else (dx * dx + dy * dy) / (1.0 - dz)
    if w == 0.0:
        return np.array([0.0, 1.0, 0.0, 0.0])
    return np.array([w, -dy, dx, 0.0]) / math.hypot(w, dy, dx)  # hypot: no underflow of tiny parts


def capsule_mesh(length_m: float, radius_m: float) -> trimesh.Trimesh:
    """A capsule along +z from z = 0 to z = ``length_m`` (segment end points on the axis)."""
    mesh = trimesh.creation.capsule(height=max(length_m, 1e-6), radius=radius_m, count=[12, 12])
    mesh.apply_translation([0.0, 0.0, length_m / 2.0])
    return mesh


def polyline_segments(points_m: np.ndarray, closed: bool = True) -> np.ndarray:
    """Shape (n, 2 or 3) vertices -> shape (m, 2, 3) segments for ``add_line_segments``."""
    p = np.asarray(points_m, dtype=float)
    if p.shape[1] == 2:
        p = np.hstack([p, np.zeros((len(p), 1))])
    ends = np.roll(p, -1, axis=0) if closed else p[1:]
    starts = p if closed else p[:-1]
    return np.stack([starts, ends], axis=1)


def circle_points(center_m: tuple[float, float], radius_m: float, count: int = 72) -> np.ndarray:
    """Shape (count, 2): a circle in the plane."""
    angles = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    return np.column_stack([center_m[0] + radius_m * np.cos(angles), center_m[1] + radius_m * np.sin(angles)])


def distance_colour(distance_m: float | None, amber_m: float = 0.5, red_m: float = 0.2) -> tuple[int, int, int]:
    """Green far away, amber below ``amber_m``, red below ``red_m`` (linear blend in between)."""
    if distance_m is None or not np.isfinite(distance_m):
        return GREY
    if distance_m <= red_m:
        return RED
    if distance_m >= amber_m:
        return GREEN
    t = (distance_m - red_m) / (amber_m - red_m)  # 0 at red, 1 at amber
    if t < 0.5:
        a, b, s = RED, AMBER, 2 * t
    else:
        a, b, s = AMBER, GREEN, 2 * t - 1
    return tuple(int(round(x + (y - x) * s)) for x, y in zip(a, b))
