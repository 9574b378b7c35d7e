"""Paper 1's limitations A-G as constraint objects on the planar Cartesian command.

Each limitation reports, at the current kinematics, one or more ``Measure``: a signed distance
``d`` (positive where allowed; [m], or [rad] for joints) and its gradient ``(gx, gy)`` with
respect to the commanded end-effector velocity, so that ``d_dot = gx * vx + gy * vy``. The
half-space is then ``(g / |g|) . v >= approach_bound(d, ...) / |g|`` (``approach_bound``
below): sliding at the limit, a damped zone before it, and no step of ``dt`` that can cross it.
The planar step projects the command onto those rows with the package's one projection
(``cobotsafety.least_distance``).

  A base collision circle, C inner reach, F end-effector circle zone: ``CircleKeepOut``
  E extended reach: ``CircleKeepIn``
  B joint 2, D joint 1: ``JointLimit`` (normal = row i of K = J^-1, errata 1-2)
  F rectangle and triangle zones: ``RectangleZone``, ``PolygonZone``
  G link protection zones through ``J_c J^-1`` (eq. 8): ``LinkCircleZone``
  III.C.2 Jacobian conditioning: ``Conditioning``
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cobotsafety.planar.rr_arm import Kinematics


#: One measure is a plain tuple ``(distance, gx, gy, name, angular)`` (tuples, not a NamedTuple:
#: this is the planar step's hot path): signed distance [m or rad], its gradient with respect
#: to the end-effector command [1 or rad/m], a display name, and whether it is angular.
Measure = tuple


@dataclass(frozen=True)
class Damping:
    """Damped-zone widths (paper 1, III.C.1); zero = hard limitation."""

    width_m: float = 0.0
    width_rad: float = 0.0


def approach_bound(distance: float, dt_s: float, v_normal_desired: float = 0.0, damping_width: float = 0.0) -> float:
    """Lower bound on ``normal @ v`` [m/s] for a limitation at signed ``distance`` [m or rad].

    Three rules: with ``d >= 0`` one step of ``dt_s`` may close at most the remaining gap,
    ``normal @ v >= -d / dt_s``; with ``d < 0`` (already inside) only motions that do not deepen
    the violation, ``normal @ v >= 0``; and paper 1's damped zone (III.C.1): within
    ``damping_width`` of the limit the allowed approach shrinks in proportion to the distance,
    from the desired normal speed ``v_normal_desired`` at the zone's edge to zero at the limit
    (``damping_width = 0``: the hard limitation).
    """
    if distance <= 0.0:
        return 0.0
    bound = -distance / dt_s
    if damping_width > 0.0 and distance < damping_width and v_normal_desired < 0.0:
        bound = max(bound, (distance / damping_width) * v_normal_desired)
    return bound


class PlanarLimitation:
    """Base class: subclasses implement ``measures(kin)``."""

    name: str

    #: Whether the distances are angles [rad] (joint limits, conditioning) or lengths [m].
    angular: bool = False

    def measures(self, kin: Kinematics) -> list[Measure]:
        raise NotImplementedError

    def distances(self, kin: Kinematics) -> list[float]:
        """The measures' signed distances only, in the same order (the safety net's check).

        ``kin`` may be built with ``jacobian=False``. Overridden where that saves work; each
        override equals ``[m[0] for m in self.measures(kin)]`` (tested).
        """
        return [m[0] for m in self.measures(kin)]

    def rows(self, kin: Kinematics, vx: float, vy: float, dt_s: float, damping: Damping,
             max_speed_m_s: float, out: list) -> None:
        """Append the active rows ``(nx, ny, bound, name)`` (unit normal, bound in m/s) to ``out``."""
        rows_from_measures(self.measures(kin), vx, vy, dt_s, damping, max_speed_m_s, out)

    def distance(self, state: Kinematics) -> float:
        return min(m[0] for m in self.measures(state))


def rows_from_measures(measures: list[Measure], vx: float, vy: float, dt_s: float,
                       damping: Damping, max_speed_m_s: float, out: list) -> None:
    """Append ``(nx, ny, bound, name)`` for every measure whose bound can bind at this speed."""
    for distance, gx, gy, name, angular in measures:
        norm = math.hypot(gx, gy)
        if norm < 1e-12:
            continue
        width = damping.width_rad if angular else damping.width_m
        bound = approach_bound(distance, dt_s, gx * vx + gy * vy, width) / norm
        if bound > -2.0 * max_speed_m_s:
            out.append((gx / norm, gy / norm, bound, name))


def _radial(px: float, py: float, cx: float, cy: float) -> tuple[float, float, float]:
    dx, dy = px - cx, py - cy
    r = math.hypot(dx, dy)
    if r < 1e-12:
        return 0.0, 1.0, 0.0  # any direction at the centre
    return r, dx / r, dy / r


@dataclass(frozen=True)
class CircleKeepOut(PlanarLimitation):
    """The end-effector stays outside a circle (A: base, C: inner reach, F: circular zone)."""

    name: str
    radius_m: float
    center_m: tuple[float, float] = (0.0, 0.0)

    def measures(self, kin: Kinematics) -> list[Measure]:
        r, ux, uy = _radial(kin.x, kin.y, *self.center_m)
        return [(r - self.radius_m, ux, uy, self.name, False)]

    def distances(self, kin: Kinematics) -> list[float]:
        return [math.hypot(kin.x - self.center_m[0], kin.y - self.center_m[1]) - self.radius_m]


@dataclass(frozen=True)
class CircleKeepIn(PlanarLimitation):
    """The end-effector stays inside a circle (E: extended reach); normal unit(-x, -y)."""

    name: str
    radius_m: float
    center_m: tuple[float, float] = (0.0, 0.0)

    def measures(self, kin: Kinematics) -> list[Measure]:
        r, ux, uy = _radial(kin.x, kin.y, *self.center_m)
        return [(self.radius_m - r, -ux, -uy, self.name, False)]

    def distances(self, kin: Kinematics) -> list[float]:
        return [self.radius_m - math.hypot(kin.x - self.center_m[0], kin.y - self.center_m[1])]


@dataclass(frozen=True)
class JointLimit(PlanarLimitation):
    """Joint ``joint`` (1 or 2) stays in [lower_rad, upper_rad]; theta_dot_i = K_i . v (eqs. 4-5).

    The normal points into the allowed range (errata 1-2): +K_i at the lower limit, -K_i at the
    upper one. Joint limits are exact under joint-space integration.
    """

    name: str
    joint: int
    lower_rad: float
    upper_rad: float
    angular = True

    def measures(self, kin: Kinematics) -> list[Measure]:
        theta, kx, ky = (kin.theta_1, kin.k11, kin.k12) if self.joint == 1 else (kin.theta_2, kin.k21, kin.k22)
        return [
            (theta - self.lower_rad, kx, ky, f"{self.name} lower", True),
            (self.upper_rad - theta, -kx, -ky, f"{self.name} upper", True),
        ]

    def distances(self, kin: Kinematics) -> list[float]:
        theta = kin.theta_1 if self.joint == 1 else kin.theta_2
        return [theta - self.lower_rad, self.upper_rad - theta]


@dataclass(frozen=True)
class RectangleZone(PlanarLimitation):
    """Axis-aligned rectangular protection zone for the end-effector (F)."""

    name: str
    center_m: tuple[float, float]
    half_size_m: tuple[float, float]

    def measures(self, kin: Kinematics) -> list[Measure]:
        dx, dy = kin.x - self.center_m[0], kin.y - self.center_m[1]
        qx, qy = abs(dx) - self.half_size_m[0], abs(dy) - self.half_size_m[1]
        sx, sy = math.copysign(1.0, dx), math.copysign(1.0, dy)
        if qx > 0.0 or qy > 0.0:
            ox, oy = max(qx, 0.0), max(qy, 0.0)
            d = math.hypot(ox, oy)
            return [(d, sx * ox / d, sy * oy / d, self.name, False)]
        if qx > qy:
            return [(qx, sx, 0.0, self.name, False)]
        return [(qy, 0.0, sy, self.name, False)]

    def vertices(self) -> list[tuple[float, float]]:
        (cx, cy), (hx, hy) = self.center_m, self.half_size_m
        return [(cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy)]


@dataclass(frozen=True)
class PolygonZone(PlanarLimitation):
    """Convex polygonal protection zone (vertices counter-clockwise), e.g. Fig. 9's triangle."""

    name: str
    vertices_m: tuple[tuple[float, float], ...]

    def measures(self, kin: Kinematics) -> list[Measure]:
        px, py = kin.x, kin.y
        n = len(self.vertices_m)
        best_out = None
        best_in = None
        for i in range(n):
            ax, ay = self.vertices_m[i]
            bx, by = self.vertices_m[(i + 1) % n]
            ex, ey = bx - ax, by - ay
            length = math.hypot(ex, ey)
            nx, ny = ey / length, -ex / length  # outward for counter-clockwise vertices
            side = (px - ax) * nx + (py - ay) * ny
            if best_in is None or side > best_in[0]:
                best_in = (side, nx, ny)
            t = min(max(((px - ax) * ex + (py - ay) * ey) / (length * length), 0.0), 1.0)
            cx, cy = ax + t * ex, ay + t * ey
            d = math.hypot(px - cx, py - cy)
            if best_out is None or d < best_out[0]:
                best_out = (d, px - cx, py - cy)
        if best_in[0] > 0.0:  # outside: distance to the closest boundary point
            d, gx, gy = best_out
            return [(d, gx / d, gy / d, self.name, False)]
        return [(best_in[0], best_in[1], best_in[2], self.name, False)]


@dataclass(frozen=True)
class LinkCircleZone(PlanarLimitation):
    """Circular protection zone that no point of either link may enter (G, eq. 8).

    For each link, the point c closest to the zone's centre moves with J_c theta_dot =
    J_c K v, so the zone's normal ``a`` at c becomes ``(J_c K)^T a`` on the command.
    """

    name: str
    center_m: tuple[float, float]
    radius_m: float

    def measures(self, kin: Kinematics) -> list[Measure]:
        cx, cy = self.center_m
        out = []
        segments = ((1, 0.0, 0.0, kin.elbow_x, kin.elbow_y), (2, kin.elbow_x, kin.elbow_y, kin.x, kin.y))
        for link, ax, ay, bx, by in segments:
            ex, ey = bx - ax, by - ay
            t = min(max(((cx - ax) * ex + (cy - ay) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
            r, ux, uy = _radial(ax + t * ex, ay + t * ey, cx, cy)
            gx, gy = kin.command_normal(kin.point_jacobian(link, t), ux, uy)
            out.append((r - self.radius_m, gx, gy, f"{self.name} link {link}", False))
        return out

    def distances(self, kin: Kinematics) -> list[float]:
        cx, cy = self.center_m
        out = []
        for ax, ay, bx, by in ((0.0, 0.0, kin.elbow_x, kin.elbow_y), (kin.elbow_x, kin.elbow_y, kin.x, kin.y)):
            ex, ey = bx - ax, by - ay
            t = min(max(((cx - ax) * ex + (cy - ay) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
            out.append(math.hypot(ax + t * ex - cx, ay + t * ey - cy) - self.radius_m)
        return out


@dataclass(frozen=True)
class Conditioning(PlanarLimitation):
    """Jacobian conditioning (III.C.2): keep sin(theta_2) = det J / (L1 L2) above ``min_sin``."""

    name: str = "conditioning"
    min_sin: float = 0.15
    angular = True

    def measures(self, kin: Kinematics) -> list[Measure]:
        c2 = math.cos(kin.theta_2)
        return [(math.sin(kin.theta_2) - self.min_sin, c2 * kin.k21, c2 * kin.k22, self.name, True)]

    def distances(self, kin: Kinematics) -> list[float]:
        return [math.sin(kin.theta_2) - self.min_sin]
