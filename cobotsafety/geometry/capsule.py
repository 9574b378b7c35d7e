"""Capsule-capsule minimum distance (paper 2, section 3), batched and robust.

Paper 2 computes the distance between the capsules' axis segments by a QR factorisation
(eq. 13, garbled in the text: erratum 4). Literal ports of that code divide by zero for
parallel, collinear or zero-length segments. Here the closest points of the two segments are
found by clamping the parameters of the closest points of the supporting lines, one segment
at a time (Ericson, *Real-Time Collision Detection*, 5.1.9), with explicit branches for the
degenerate cases; all of it vectorised over any batch shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Squared lengths [m^2] below this count as zero-length segments.
_EPS_LENGTH2 = 1e-24


@dataclass(frozen=True)
class Capsule:
    """A segment ``p0``-``p1`` [m] swept by a sphere of ``radius_m``."""

    p0: np.ndarray
    p1: np.ndarray
    radius_m: float


def segment_closest_points(a0, a1, b0, b1) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of segments a0-a1 and b0-b1. Shapes (..., 3), broadcast together.

    Returns ``(point_a, point_b)``, each of the broadcast shape (..., 3). For parallel segments
    with many closest pairs, one valid pair is returned.
    """
    a0, a1, b0, b1 = (np.asarray(x, dtype=float) for x in (a0, a1, b0, b1))
    d1 = a1 - a0
    d2 = b1 - b0
    r = a0 - b0
    # All five dot products in one call: rows d1, d2, r.
    V = np.stack(np.broadcast_arrays(d1, d2, r))
    G = np.einsum("i...k,j...k->ij...", V, V)
    a, b, c, e, f = G[0, 0], G[0, 1], G[0, 2], G[1, 1], G[1, 2]
    degenerate = not (np.all(a > _EPS_LENGTH2) and np.all(e > _EPS_LENGTH2))
    if degenerate:
        a_ok, e_ok = a > _EPS_LENGTH2, e > _EPS_LENGTH2
        a, e = np.where(a_ok, a, 1.0), np.where(e_ok, e, 1.0)
    denom = a * e - b * b
    # Non-parallel: closest points of the lines, s clamped to [0, 1]; parallel: start at s = 0.
    non_parallel = denom > 1e-12 * a * e
    s = np.clip((b * f - c * e) / np.where(non_parallel, denom, 1.0), 0.0, 1.0) * non_parallel
    # t for that s, then clamp t and recompute s where t left [0, 1].
    t = (b * s + f) / e
    s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    if degenerate:
        # Zero-length segments: the point itself, and the other segment's closest point to it.
        s = np.where(e_ok, s, np.clip(-c / a, 0.0, 1.0))
        t = np.where(e_ok, t, 0.0)
        s = np.where(a_ok, s, 0.0)
        t = np.where(a_ok, t, np.where(e_ok, np.clip(f / e, 0.0, 1.0), 0.0))
    point_a = a0 + s[..., None] * d1
    point_b = b0 + t[..., None] * d2
    shape = np.broadcast_shapes(point_a.shape, point_b.shape)
    return np.broadcast_to(point_a, shape), np.broadcast_to(point_b, shape)


def capsule_distance(a0, a1, ra, b0, b1, rb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum distance between capsules A (a0-a1, radius ra) and B (b0-b1, radius rb).

    Args:
        a0, a1, b0, b1: segment end points [m], shape (..., 3).
        ra, rb: radii [m], shape (...). Everything broadcasts together, so one call computes
            many pairs (e.g. 5 human x 3 robot capsules with shapes (5, 1, 3) and (1, 3, 3)).

    Returns:
        ``(distance, point_a, point_b)``: the axis-segment distance minus both radii [m]
        (negative when the capsules overlap), shape (...); and the closest points of the two
        axis segments, shape (..., 3). Parallel, antiparallel, collinear, zero-length and
        crossing segments are all handled without NaN.
    """
    point_a, point_b = segment_closest_points(a0, a1, b0, b1)
    gap = point_a - point_b
    axis_distance = np.sqrt(np.einsum("...i,...i->...", gap, gap))
    return axis_distance - np.asarray(ra, dtype=float) - np.asarray(rb, dtype=float), point_a, point_b
