"""Each planar limitation: its normal against finite differences of its distance function."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cobotsafety.planar.rr_arm import Kinematics, PlanarArm
from cobotsafety.planar.limitations import (
    CircleKeepIn,
    CircleKeepOut,
    Conditioning,
    JointLimit,
    LinkCircleZone,
    PolygonZone,
    RectangleZone,
)

ARM = PlanarArm()
LIMITATIONS = [
    CircleKeepOut("A base", 0.12),
    JointLimit("B joint 2", 2, ARM.theta_2_min_rad, ARM.theta_2_max_rad),
    CircleKeepOut("C inner reach", 0.05),
    JointLimit("D joint 1", 1, ARM.theta_1_min_rad, ARM.theta_1_max_rad),
    CircleKeepIn("E extended reach", 0.57),
    CircleKeepOut("F circle", 0.05, (0.2, 0.3)),
    RectangleZone("F rectangle", (-0.3, 0.2), (0.06, 0.04)),
    PolygonZone("F triangle", ((-0.24, 0.12), (-0.10, 0.12), (-0.17, 0.22))),
    LinkCircleZone("G link zone", (0.15, 0.15), 0.04),
    Conditioning(),
]


@pytest.mark.parametrize("limitation", LIMITATIONS, ids=lambda lim: lim.name)
def test_normal_is_the_gradient_of_the_distance_along_the_command(limitation):
    """d(theta + eps K v) - d(theta - eps K v) over 2 eps equals g . v for a Cartesian command v."""
    rng = np.random.default_rng(abs(hash(limitation.name)) % 2**32)
    eps = 1e-7
    checked = 0
    for _ in range(300):
        t1 = rng.uniform(ARM.theta_1_min_rad, ARM.theta_1_max_rad)
        t2 = rng.uniform(ARM.theta_2_min_rad, ARM.theta_2_max_rad)
        kin = Kinematics(ARM, t1, t2)
        v = rng.normal(size=2)
        dt1, dt2 = kin.k11 * v[0] + kin.k12 * v[1], kin.k21 * v[0] + kin.k22 * v[1]
        plus = limitation.measures(Kinematics(ARM, t1 + eps * dt1, t2 + eps * dt2))
        minus = limitation.measures(Kinematics(ARM, t1 - eps * dt1, t2 - eps * dt2))
        for m, mp, mm in zip(limitation.measures(kin), plus, minus):
            if abs(mp[0] - mm[0]) > 0 and abs((mp[0] - m[0]) - (m[0] - mm[0])) > 1e-9:
                continue  # a kink (closest feature changed): no derivative there
            finite_difference = (mp[0] - mm[0]) / (2 * eps)
            assert m[1] * v[0] + m[2] * v[1] == pytest.approx(finite_difference, rel=1e-5, abs=1e-6)
            checked += 1
    assert checked >= 250


def test_joint_normals_point_into_the_allowed_range():
    """Errata 1-2: joint 1 uses row 1 of K, and each side's normal points into the range."""
    kin = Kinematics(ARM, 1.0, 1.5)
    lower, upper = JointLimit("D", 1, -0.6, 3.7).measures(kin)
    assert (lower[1], lower[2]) == (kin.k11, kin.k12)
    assert (upper[1], upper[2]) == (-kin.k11, -kin.k12)
    lower2, _ = JointLimit("B", 2, 0.25, 2.6).measures(kin)
    assert (lower2[1], lower2[2]) == (kin.k21, kin.k22)


def test_signed_distances_on_hand_worked_points():
    t1, t2 = ARM.inverse_kinematics(-0.3, 0.2)  # the rectangle's centre
    kin = Kinematics(ARM, t1, t2)
    assert RectangleZone("F", (-0.3, 0.2), (0.06, 0.04)).distance(kin) == pytest.approx(-0.04)
    t1, t2 = ARM.inverse_kinematics(0.0, 0.45)
    kin = Kinematics(ARM, t1, t2)
    assert CircleKeepIn("E", 0.57).distance(kin) == pytest.approx(0.12)
    assert CircleKeepOut("A", 0.12).distance(kin) == pytest.approx(0.33)
    tri = PolygonZone("T", ((-0.24, 0.12), (-0.10, 0.12), (-0.17, 0.22)))
    t1, t2 = ARM.inverse_kinematics(-0.17, 0.02)  # 10 cm under the bottom edge
    assert tri.distance(Kinematics(ARM, t1, t2)) == pytest.approx(0.10)
    assert math.isfinite(Conditioning().distance(kin))
