"""Planar arm kinematics against finite differences."""

from __future__ import annotations

import math

import numpy as np

from cobotsafety.planar.rr_arm import Kinematics, PlanarArm

ARM = PlanarArm()


def random_angles(rng):
    return rng.uniform(ARM.theta_1_min_rad, ARM.theta_1_max_rad), rng.uniform(ARM.theta_2_min_rad, ARM.theta_2_max_rad)


def test_jacobian_matches_finite_differences_and_k_inverts_it():
    rng = np.random.default_rng(0)
    eps = 1e-7
    for _ in range(200):
        t1, t2 = random_angles(rng)
        kin = Kinematics(ARM, t1, t2)
        J = np.array([[kin.j11, kin.j12], [kin.j21, kin.j22]])
        for j, (d1, d2) in enumerate(((eps, 0.0), (0.0, eps))):
            plus, minus = Kinematics(ARM, t1 + d1, t2 + d2), Kinematics(ARM, t1 - d1, t2 - d2)
            column = np.array([plus.x - minus.x, plus.y - minus.y]) / (2 * eps)
            np.testing.assert_allclose(J[:, j], column, atol=1e-8)
        K = np.array([[kin.k11, kin.k12], [kin.k21, kin.k22]])
        np.testing.assert_allclose(K @ J, np.eye(2), atol=1e-9)


def test_point_jacobians_match_finite_differences():
    rng = np.random.default_rng(1)
    eps = 1e-7

    def point(t1, t2, link, t):
        kin = Kinematics(ARM, t1, t2)
        if link == 1:
            return np.array([t * kin.elbow_x, t * kin.elbow_y])
        return np.array([kin.elbow_x + t * (kin.x - kin.elbow_x), kin.elbow_y + t * (kin.y - kin.elbow_y)])

    for _ in range(100):
        t1, t2 = random_angles(rng)
        link, t = int(rng.integers(1, 3)), rng.uniform()
        Jc = np.array(Kinematics(ARM, t1, t2).point_jacobian(link, t)).reshape(2, 2)
        fd = np.column_stack([
            (point(t1 + eps, t2, link, t) - point(t1 - eps, t2, link, t)) / (2 * eps),
            (point(t1, t2 + eps, link, t) - point(t1, t2 - eps, link, t)) / (2 * eps),
        ])
        np.testing.assert_allclose(Jc, fd, atol=1e-8)


def test_inverse_kinematics_round_trip_and_fig9_start():
    t1, t2 = ARM.inverse_kinematics(-0.2, 0.03)
    kin = Kinematics(ARM, t1, t2)
    assert (kin.x, kin.y) == (np.float64(kin.x), np.float64(kin.y))
    assert math.isclose(kin.x, -0.2, abs_tol=1e-12) and math.isclose(kin.y, 0.03, abs_tol=1e-12)
    assert ARM.theta_2_min_rad < t2 < ARM.theta_2_max_rad
    assert ARM.theta_1_min_rad < t1 < ARM.theta_1_max_rad


def test_damped_inverse_is_finite_at_the_singularity():
    kin = Kinematics(ARM, 0.3, 0.0)  # arm stretched: det J = 0
    values = [kin.k11, kin.k12, kin.k21, kin.k22]
    assert all(math.isfinite(v) for v in values)
    assert max(abs(v) for v in values) < 1e4


