"""Protection zones in 3D and their distance to every robot capsule, with witness points.

Each zone's ``capsule_distances(p0, p1, radius)`` takes the robot capsules (c, 3), (c, 3), (c,)
and returns ``(distance (c,), p_robot (c, 3), u_world (c, 3))``: the signed clearance [m]
(negative inside), the point of each capsule's axis closest to the zone, and the unit
direction in which moving that point increases the clearance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.geometry.capsule import capsule_distance


def _unit(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-12, v / np.where(n > 1e-12, n, 1.0), fallback)


@dataclass(frozen=True)
class CapsuleZone:
    """A capsule-shaped protection zone (segment ``p0``-``p1`` [m], ``radius_m``)."""

    name: str
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    radius_m: float

    def capsule_distances(self, p0, p1, radius):
        d, p_robot, p_zone = capsule_distance(p0, p1, radius, np.asarray(self.p0), np.asarray(self.p1), self.radius_m)
        return d, p_robot, _unit(p_robot - p_zone, np.array([0.0, 0.0, 1.0]))


@dataclass(frozen=True)
class SphereZone(CapsuleZone):
    """A spherical protection zone: a capsule of zero length."""

    def __init__(self, name: str, center: tuple[float, float, float], radius_m: float):
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "p0", tuple(center))
        object.__setattr__(self, "p1", tuple(center))
        object.__setattr__(self, "radius_m", radius_m)

    @property
    def center(self) -> tuple[float, float, float]:
        return self.p0


@dataclass(frozen=True)
class HalfSpaceZone:
    """Everything on the side ``normal`` points to from ``point`` is forbidden (e.g. a wall)."""

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]

    def capsule_distances(self, p0, p1, radius):
        n = np.asarray(self.normal, dtype=float)
        n = n / np.linalg.norm(n)
        s0, s1 = (p0 - self.point) @ n, (p1 - self.point) @ n
        deepest = np.where((s0 >= s1)[:, None], p0, p1)
        d = -np.maximum(s0, s1) - radius
        return d, deepest, np.broadcast_to(-n, deepest.shape)


@dataclass(frozen=True)
class BoxZone:
    """An axis-aligned box ``center`` +- ``half_size`` [m]."""

    name: str
    center: tuple[float, float, float]
    half_size: tuple[float, float, float]

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        """``(centre (3,), radius)`` [m] of the sphere through the corners: a cheap lower bound."""
        return np.asarray(self.center, dtype=float), float(np.linalg.norm(self.half_size))

    def capsule_distances(self, p0, p1, radius):
        """Exact segment-box distance: the squared outside distance along a segment is a convex
        piecewise quadratic of the segment parameter, with pieces split where a coordinate
        crosses a face plane; each piece's minimiser is closed-form. Penetrating segments
        (distance 0) get the box's signed distance minimised exactly too (see below)."""
        c, h = np.asarray(self.center, dtype=float), np.asarray(self.half_size, dtype=float)
        x0 = p0 - c
        seg = p1 - p0
        with np.errstate(divide="ignore", invalid="ignore"):
            crossings = np.concatenate([(h - x0) / seg, (-h - x0) / seg], axis=1)
        crossings = np.where(np.isfinite(crossings) & (crossings > 0) & (crossings < 1), crossings, 1.0)
        knots = np.sort(np.concatenate([np.zeros((len(p0), 1)), crossings, np.ones((len(p0), 1))], axis=1), axis=1)
        a, b = knots[:, :-1], knots[:, 1:]
        mid = x0[:, None, :] + 0.5 * (a + b)[..., None] * seg[:, None, :]
        face = np.where(mid > h, h, np.where(mid < -h, -h, np.nan))
        active = np.isfinite(face)
        offset = np.where(active, x0[:, None, :] - np.nan_to_num(face), 0.0)
        slope = np.where(active, seg[:, None, :], 0.0)
        num = -(offset * slope).sum(axis=2)
        den = (slope * slope).sum(axis=2)
        t_star = np.clip(np.where(den > 1e-18, num / np.where(den > 1e-18, den, 1.0), a), a, b)
        x = x0[:, None, :] + t_star[..., None] * seg[:, None, :]
        outside = np.maximum(np.abs(x) - h, 0.0)
        f = (outside * outside).sum(axis=2)
        best = np.argmin(f, axis=1)
        rows = np.arange(len(p0))
        t = t_star[rows, best]
        if np.any(f[rows, best] <= 1e-24):
            # Touching or penetrating: inside, the signed distance max_k(sigma x_k - h_k) is
            # piecewise linear along the segment, so its minimum is at an end or where two of
            # the six face functions cross; evaluate them all.
            sigma = np.array([1.0, -1.0])
            slopes = (sigma[None, :, None] * seg[:, None, :]).reshape(len(p0), 6)
            values0 = (sigma[None, :, None] * x0[:, None, :] - h).reshape(len(p0), 6)
            i, j = np.triu_indices(6, 1)
            with np.errstate(divide="ignore", invalid="ignore"):
                cross = (values0[:, j] - values0[:, i]) / (slopes[:, i] - slopes[:, j])
            cross = np.where(np.isfinite(cross), np.clip(cross, 0.0, 1.0), 0.0)
            candidates = np.concatenate([cross, np.zeros((len(p0), 1)), np.ones((len(p0), 1)), t[:, None]], axis=1)
            pts = x0[:, None, :] + candidates[..., None] * seg[:, None, :]
            q = np.abs(pts) - h
            sdf = np.linalg.norm(np.maximum(q, 0.0), axis=2) + np.minimum(q.max(axis=2), 0.0)
            inside = f[rows, best] <= 1e-24
            pick = np.argmin(sdf, axis=1)
            t = np.where(inside, candidates[rows, pick], t)
            # At a crossing of the two maximal faces k and l the minimum moves with both: its
            # gradient with respect to a translation is the slope-weighted mix of their normals.
            face_values = values0 + t[:, None] * slopes
            top = face_values.max(axis=1, keepdims=True)
            active = np.abs(face_values - top) < 1e-12
            two = inside & (active.sum(axis=1) == 2) & (top[:, 0] < 0)
            if np.any(two):
                order = np.argsort(~active, axis=1, kind="stable")
                k, l = order[:, 0], order[:, 1]
                s_k, s_l = slopes[rows, k], slopes[rows, l]
                valid = two & (s_k * s_l < 0)
                denom = np.where(valid, s_l - s_k, 1.0)
                normals6 = np.concatenate([np.eye(3), -np.eye(3)])
                u_cross = (s_l / denom)[:, None] * normals6[k] - (s_k / denom)[:, None] * normals6[l]
                p = p0 + t[:, None] * seg
                d, u = _point_box(p, c, h)
                return d - radius, p, np.where(valid[:, None], u_cross, u)
        p = p0 + t[:, None] * seg
        d, u = _point_box(p, c, h)
        return d - radius, p, u


def _point_box(p: np.ndarray, c: np.ndarray, h: np.ndarray):
    """Signed distance of points (k, 3) to a box and the direction that increases it."""
    local = p - c
    q = np.abs(local) - h
    outside = np.maximum(q, 0.0)
    out_norm = np.linalg.norm(outside, axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    d = out_norm + inside
    sign = np.where(local >= 0, 1.0, -1.0)
    u_out = sign * outside / np.where(out_norm > 0, out_norm, 1.0)[:, None]
    axis = np.argmax(q, axis=1)
    u_in = np.zeros_like(p)
    u_in[np.arange(len(p)), axis] = sign[np.arange(len(p)), axis]
    return d, np.where((out_norm > 0)[:, None], u_out, u_in)
