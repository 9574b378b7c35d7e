"""The planar RR arm of paper 1 (a modified Kinova JACO), kinematic only.

Defaults: two links of 0.30 m. The paper does not give its link lengths; the JACO's shoulder-
elbow and elbow-wrist distances are of that order, and with L1 = L2 = 0.30 m the Fig. 9 start
(-0.2, 0.03) m lies mid-workspace (r = 0.202 m, elbow at 140.6 deg) between the joint-2 inner
circle (r = 0.160 m at theta2 = 2.6 rad) and the extended-reach circle (0.57 m), as the figure
shows. Equal links put the inner-reach singularity (C) at the base itself, so, as the paper says,
joint 2's limit (B) is the most restrictive inner circle, ahead of the base collision circle (A).
The elbow works on one side (theta2 > 0), so theta2 = 0 (arm stretched, a singularity) is the
extended-reach limit and is kept away by the lower joint-2 limit and the reach circle E.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PlanarArm:
    """Link lengths [m] and joint ranges [rad] of the RR arm."""

    link_1_m: float = 0.30
    link_2_m: float = 0.30
    theta_1_min_rad: float = -0.6
    theta_1_max_rad: float = 3.7
    theta_2_min_rad: float = 0.25
    theta_2_max_rad: float = 2.6

    def inverse_kinematics(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Joint angles (elbow on the theta2 > 0 side) that put the end-effector at (x, y)."""
        l1, l2 = self.link_1_m, self.link_2_m
        c2 = (x_m * x_m + y_m * y_m - l1 * l1 - l2 * l2) / (2 * l1 * l2)
        if not -1.0 <= c2 <= 1.0:
            raise ValueError(f"point ({x_m}, {y_m}) is out of reach of the arm")
        theta_2 = math.acos(c2)
        theta_1 = math.atan2(y_m, x_m) - math.atan2(l2 * math.sin(theta_2), l1 + l2 * math.cos(theta_2))
        return theta_1, theta_2


class Kinematics:
    """Everything one step needs at joint angles (theta_1, theta_2), computed once.

    Attributes (floats): ``x, y`` end-effector [m]; ``elbow_x, elbow_y`` [m]; Jacobian
    ``j11 j12 j21 j22`` [m/rad] of the end-effector; its inverse ``k11 k12 k21 k22`` [rad/m]
    (``K = J^-1``, eq. 3); ``det`` [m^2]. Near a singularity ``k`` is the damped inverse
    ``J^T (J J^T + lambda^2 I)^-1``, so it never blows up. With ``jacobian=False`` only the
    angles and positions are set (the safety net's distance checks); reading ``j``/``k`` then
    raises ``AttributeError``.
    """

    __slots__ = ("arm", "theta_1", "theta_2", "x", "y", "elbow_x", "elbow_y",
                 "j11", "j12", "j21", "j22", "k11", "k12", "k21", "k22", "det")

    #: Damping [m] of the inverse below which |det J| counts as singular.
    DAMPING_M = 1e-3

    def __init__(self, arm: PlanarArm, theta_1: float, theta_2: float, jacobian: bool = True):
        self.arm, self.theta_1, self.theta_2 = arm, theta_1, theta_2
        l1, l2 = arm.link_1_m, arm.link_2_m
        c1, s1 = math.cos(theta_1), math.sin(theta_1)
        c12, s12 = math.cos(theta_1 + theta_2), math.sin(theta_1 + theta_2)
        self.elbow_x, self.elbow_y = l1 * c1, l1 * s1
        self.x, self.y = self.elbow_x + l2 * c12, self.elbow_y + l2 * s12
        if not jacobian:
            return
        self.j11, self.j12 = -l1 * s1 - l2 * s12, -l2 * s12
        self.j21, self.j22 = l1 * c1 + l2 * c12, l2 * c12
        det = self.j11 * self.j22 - self.j12 * self.j21
        self.det = det
        lam2 = self.DAMPING_M**2
        if abs(det) > 10 * self.DAMPING_M:
            inv = 1.0 / det
            self.k11, self.k12 = self.j22 * inv, -self.j12 * inv
            self.k21, self.k22 = -self.j21 * inv, self.j11 * inv
        else:  # damped least squares: J^T (J J^T + lambda^2 I)^-1
            a = self.j11 * self.j11 + self.j12 * self.j12 + lam2
            b = self.j11 * self.j21 + self.j12 * self.j22
            d = self.j21 * self.j21 + self.j22 * self.j22 + lam2
            inv = 1.0 / (a * d - b * b)
            m11, m12, m22 = d * inv, -b * inv, a * inv
            self.k11 = self.j11 * m11 + self.j21 * m12
            self.k12 = self.j11 * m12 + self.j21 * m22
            self.k21 = self.j12 * m11 + self.j22 * m12
            self.k22 = self.j12 * m12 + self.j22 * m22

    def point_jacobian(self, on_link: int, t: float) -> tuple[float, float, float, float]:
        """Jacobian [m/rad] of the point at fraction ``t`` along link 1 or 2 (row-major)."""
        ex_1, ey_1 = -self.elbow_y, self.elbow_x  # elbow velocity per unit theta_1
        if on_link == 1:
            return t * ex_1, 0.0, t * ey_1, 0.0
        return (ex_1 + t * (self.j11 - ex_1), t * self.j12, ey_1 + t * (self.j21 - ey_1), t * self.j22)

    def command_normal(self, jacobian: tuple[float, float, float, float], ax: float, ay: float) -> tuple[float, float]:
        """Map a normal ``a`` at a robot point to the command: ``(J_c K)^T a`` (eq. 8)."""
        c11, c12, c21, c22 = jacobian
        # M = J_c K
        m11 = c11 * self.k11 + c12 * self.k21
        m12 = c11 * self.k12 + c12 * self.k22
        m21 = c21 * self.k11 + c22 * self.k21
        m22 = c21 * self.k12 + c22 * self.k22
        return m11 * ax + m21 * ay, m12 * ax + m22 * ay
