"""Small pure helpers shared by the scene views: polylines, capsule meshes, arcs, colours, quaternions.

Positions are in the robot base frame [m]; viser wants ``wxyz`` quaternions, the project API uses
``xyzw``: ``wxyz_from_xyzw`` converts at the scene boundary.

The capsule mesh is made here with numpy (rings of a UV sphere split at its equator): the
planar demo needs nothing else from a mesh library, and importing trimesh (with scipy behind
it) cost 1-3 s of the demo's start-up. ``tests/test_app_draw.py`` holds it to trimesh's
measures (watertight, outward, volume).
"""

from __future__ import annotations

import math

import numpy as np

GREEN = (40, 180, 80)
AMBER = (240, 170, 20)
RED = (220, 40, 40)
GREY = (120, 120, 130)
HIGHLIGHT = (255, 60, 200)
ZONE = (120, 105, 210)
"""Protection zones: a cool violet, apart from the human's green-amber-red and the highlight."""


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


def capsule_mesh(length_m: float, radius_m: float, segments: int = 16, rings: int = 6
                 ) -> tuple[np.ndarray, np.ndarray]:
    """A closed capsule along +z, axis from z = 0 to z = ``length_m``: ``(vertices (n, 3)
    float32 [m], faces (f, 3) uint32)``, faces counter-clockwise seen from outside.

    ``segments`` vertices round each ring, ``rings`` rings per half sphere (equator included).
    ``length_m = 0`` gives a sphere of ``radius_m`` centred at the origin.
    """
    angles = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    circle = np.column_stack([np.cos(angles), np.sin(angles)])
    polar = np.linspace(0.0, 0.5 * np.pi, rings + 1)[1:]  # from the pole to the equator
    rows = [(math.sin(a), -math.cos(a), 0.0) for a in polar]  # lower half: (ring radius, z, axis offset)
    rows += [(math.sin(a), math.cos(a), length_m) for a in polar[::-1]]  # upper half, equator first
    ring_points = [np.column_stack([circle * (radius_m * r), np.full(segments, radius_m * z + offset)])
                   for r, z, offset in rows]
    vertices = np.vstack([[0.0, 0.0, -radius_m], *ring_points, [0.0, 0.0, length_m + radius_m]])
    top = len(vertices) - 1
    nxt = (np.arange(segments) + 1) % segments
    here = np.arange(segments)
    faces = [np.column_stack([np.zeros(segments, int), 1 + nxt, 1 + here])]  # the lower pole's fan
    for row in range(len(rows) - 1):
        a, b = 1 + row * segments, 1 + (row + 1) * segments
        faces.append(np.column_stack([a + here, a + nxt, b + nxt]))
        faces.append(np.column_stack([a + here, b + nxt, b + here]))
    last = 1 + (len(rows) - 1) * segments
    faces.append(np.column_stack([np.full(segments, top), last + here, last + nxt]))  # the upper pole's fan
    return vertices.astype(np.float32), np.vstack(faces).astype(np.uint32)


def tube_mesh(segments: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """An open unit cylinder (radius 1, z from 0 to 1, no caps): ``(vertices, faces)`` as
    ``capsule_mesh``; scaled per instance and closed by spheres at its ends (the human)."""
    angles = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles)])
    vertices = np.vstack([np.column_stack([ring, np.zeros(segments)]), np.column_stack([ring, np.ones(segments)])])
    here, nxt = np.arange(segments), (np.arange(segments) + 1) % segments
    faces = np.vstack([np.column_stack([here, nxt, segments + nxt]), np.column_stack([here, segments + nxt, segments + here])])
    return vertices.astype(np.float32), faces.astype(np.uint32)


def arc_points(center_m, axis, start, from_rad: float, to_rad: float, radius_m: float, count: int = 24) -> np.ndarray:
    """Shape (count, 3): an arc of ``radius_m`` about ``axis`` through ``center_m``, from angle
    ``from_rad`` to ``to_rad`` measured from ``start`` (any vector not along the axis) by the
    right-hand rule about the axis."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    start = np.asarray(start, dtype=float)
    start = start - (start @ axis) * axis
    start = start / np.linalg.norm(start)
    side = np.cross(axis, start)
    angles = np.linspace(from_rad, to_rad, count)
    return np.asarray(center_m, float) + radius_m * (np.outer(np.cos(angles), start) + np.outer(np.sin(angles), side))


def sphere_wireframe(center_m, radius_m: float, latitudes: int = 5, meridians: int = 8, count: int = 48) -> np.ndarray:
    """Shape (m, 2, 3) segments: ``latitudes`` circles of latitude and ``meridians`` great
    circles through the poles of a sphere (a see-through sphere drawn as lines)."""
    center = np.asarray(center_m, dtype=float)
    parts = []
    for polar in np.linspace(0.0, np.pi, latitudes + 2)[1:-1]:
        ring = circle_points((0.0, 0.0), radius_m * math.sin(polar), count)
        parts.append(polyline_segments(np.column_stack([ring, np.full(count, radius_m * math.cos(polar))]) + center))
    for azimuth in np.linspace(0.0, np.pi, meridians, endpoint=False):
        polar = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
        points = radius_m * np.column_stack([np.sin(polar) * math.cos(azimuth), np.sin(polar) * math.sin(azimuth),
                                             np.cos(polar)])
        parts.append(polyline_segments(points + center))
    return np.concatenate(parts)


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
