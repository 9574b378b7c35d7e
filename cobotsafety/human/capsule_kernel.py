"""The 5-capsule human in one compiled call: slerp, eq. 6, eqs. 7-12 and the margin.

The readable reference is ``timing.rotations_at`` (slerp) -> ``Rotation`` products (eq. 6) ->
``capsules.five_capsules`` (``imu.arm_chain``, eqs. 7-12) -> ``conservative.conservative_capsules``
(radius + ``growth``). Those build ~10 scipy/numpy objects for 5 rotations and 5 capsules; this
kernel does the same arithmetic on the raw quaternions in one numba call (``HumanTracker``'s
per-frame path). ``tests/test_capsule_kernel.py`` holds the two equal on random inputs.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from cobotsafety.human.body import BodyDimensions

#: Below this angle [rad] between two samples, slerp is a normalised lerp (error ~ angle^3).
_SLERP_LINEAR_BELOW_RAD = 1e-6


def body_vector(body: BodyDimensions) -> np.ndarray:
    """The dimensions the kernel reads, shape (10,) [m], in ``_five_capsules_kernel``'s order."""
    return np.array([body.d1_m, body.d2_m, body.d3_m, body.d4_m, body.chest_height_m,
                     body.torso_below_chest_m, body.head_above_chest_m, body.torso_radius_m,
                     body.upper_arm_radius_m, body.forearm_radius_m])


@numba.njit(cache=True)
def _slerp_matrix(q0, q1, frac, out):  # pragma: no cover - compiled
    """Rotation matrix (3, 3) of the shortest-arc slerp from unit xyzw ``q0`` to ``q1``."""
    dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    sign = 1.0
    if dot < 0.0:
        sign, dot = -1.0, -dot
    angle = math.acos(min(dot, 1.0))
    if frac == 0.0:
        w0, w1 = 1.0, 0.0
    elif angle < _SLERP_LINEAR_BELOW_RAD:
        w0, w1 = 1.0 - frac, frac
    else:
        w0 = math.sin((1.0 - frac) * angle) / math.sin(angle)
        w1 = math.sin(frac * angle) / math.sin(angle)
    x = w0 * q0[0] + sign * w1 * q1[0]
    y = w0 * q0[1] + sign * w1 * q1[1]
    z = w0 * q0[2] + sign * w1 * q1[2]
    w = w0 * q0[3] + sign * w1 * q1[3]
    n2 = x * x + y * y + z * z + w * w
    s = 2.0 / n2
    out[0, 0], out[0, 1], out[0, 2] = 1.0 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)
    out[1, 0], out[1, 1], out[1, 2] = s * (x * y + z * w), 1.0 - s * (x * x + z * z), s * (y * z - x * w)
    out[2, 0], out[2, 1], out[2, 2] = s * (x * z - y * w), s * (y * z + x * w), 1.0 - s * (x * x + y * y)


@numba.njit(cache=True)
def _five_capsules_kernel(xy, q0, q1, frac, r_b_ref, body, growth, p0, p1, radius):  # pragma: no cover
    """``xy`` (2,), ``q0``/``q1`` (5, 4) xyzw, ``frac`` (5,), ``r_b_ref`` (5, 3, 3), ``body`` (10,)
    and ``growth`` [m] in; ``p0``/``p1`` (5, 3), ``radius`` (5,) out. Returns False when a
    result is not finite (the caller then takes the validating path)."""
    d1, d2, d3, d4, chest, below, above = body[0], body[1], body[2], body[3], body[4], body[5], body[6]
    r_ref_imu = np.empty((3, 3))
    m = np.empty((5, 3, 3))  # R_b_imu = R_b_ref R_ref_imu (eq. 6)
    for i in range(5):
        _slerp_matrix(q0[i], q1[i], frac[i], r_ref_imu)
        for r in range(3):
            for c in range(3):
                m[i, r, c] = (r_b_ref[i, r, 0] * r_ref_imu[0, c] + r_b_ref[i, r, 1] * r_ref_imu[1, c]
                              + r_b_ref[i, r, 2] * r_ref_imu[2, c])
    chest_point = np.empty(3)  # eq. 9
    chest_point[0], chest_point[1], chest_point[2] = xy[0], xy[1], chest
    for a in range(3):
        chest_a = chest_point[a]
        # torso: vertical axis through the chest point
        p0[0, a] = chest_a if a < 2 else chest - below
        p1[0, a] = chest_a if a < 2 else chest + above
        shoulder_left = chest_a - d1 * m[0, a, 0] + d2 * m[0, a, 1]  # eqs. 7-8, erratum 7
        shoulder_right = chest_a - d1 * m[0, a, 0] - d2 * m[0, a, 1]
        elbow_left = shoulder_left + d3 * m[1, a, 0]  # eq. 11
        elbow_right = shoulder_right + d3 * m[3, a, 0]
        p0[1, a], p1[1, a] = shoulder_left, elbow_left
        p0[2, a], p1[2, a] = elbow_left, elbow_left + d4 * m[2, a, 0]  # eq. 12
        p0[3, a], p1[3, a] = shoulder_right, elbow_right
        p0[4, a], p1[4, a] = elbow_right, elbow_right + d4 * m[4, a, 0]
    radius[0] = body[7] + growth
    radius[1] = radius[3] = body[8] + growth
    radius[2] = radius[4] = body[9] + growth
    finite = True
    for i in range(5):
        finite &= np.isfinite(radius[i]) and radius[i] >= 0.0
        for a in range(3):
            finite &= np.isfinite(p0[i, a]) and np.isfinite(p1[i, a])
    return finite


def five_capsules_packed(xy_b_torso_m, q0_ref_imu, q1_ref_imu, frac, r_b_ref, body_vec, growth_m):
    """``(p0 (5, 3), p1 (5, 3), radius (5,), finite)`` [m]; arguments as the kernel's."""
    p0, p1, radius = np.empty((5, 3)), np.empty((5, 3)), np.empty(5)
    finite = _five_capsules_kernel(xy_b_torso_m, q0_ref_imu, q1_ref_imu, frac, r_b_ref, body_vec,
                                   float(growth_m), p0, p1, radius)
    return p0, p1, radius, finite
