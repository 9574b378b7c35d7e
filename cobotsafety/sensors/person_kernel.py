"""The person tracker's per-scan arithmetic in compiled loops (``PersonTracker(packed=True)``).

The readable reference is ``ConstantVelocityKalman.predict`` / ``.update`` and the numpy gate
of ``PersonTracker._assign_legs``: a few dozen numpy calls on (n, 2) arrays per scan, whose
call overhead was most of the sensor frame's tracker time. These kernels do the same sums in
place on the filter's own arrays (its state stays the one ``ConstantVelocityKalman`` holds);
``tests/test_person_tracker.py`` holds both paths equal on random walkers.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def predict_in_place(position, velocity, covariance, dt, accel_density):  # pragma: no cover - compiled
    """``x <- F x``, ``P <- F P F^T + Q`` for every point (see ``constant_velocity``), dt >= 0 [s]."""
    q00 = accel_density * dt ** 3 / 3.0
    q01 = accel_density * dt ** 2 / 2.0
    q11 = accel_density * dt
    for i in range(position.shape[0]):
        for a in range(position.shape[1]):
            position[i, a] += dt * velocity[i, a]
        p00, p01, p10, p11 = covariance[i, 0, 0], covariance[i, 0, 1], covariance[i, 1, 0], covariance[i, 1, 1]
        covariance[i, 0, 0] = p00 + dt * (p10 + p01) + dt * dt * p11 + q00
        covariance[i, 0, 1] = p01 + dt * p11 + q01
        covariance[i, 1, 0] = p10 + dt * p11 + q01
        covariance[i, 1, 1] = p11 + q11


@numba.njit(cache=True)
def leg_gate(position, covariance, legs, extra_variance, gate, cost):  # pragma: no cover - compiled
    """Squared Mahalanobis distance of every leg (k, 2) to every predicted torso (n, 2) into
    ``cost`` (n, k); returns True when the gated assignment is unambiguous (every leg within
    the gate of at most one track, no track with more than two legs)."""
    n, k = position.shape[0], legs.shape[0]
    per_leg = np.zeros(k, dtype=np.int64)
    unambiguous = True
    for i in range(n):
        variance = covariance[i, 0, 0] + extra_variance
        allowed = 0
        for j in range(k):
            dx, dy = position[i, 0] - legs[j, 0], position[i, 1] - legs[j, 1]
            cost[i, j] = (dx * dx + dy * dy) / variance
            if cost[i, j] <= gate:
                allowed += 1
                per_leg[j] += 1
        unambiguous &= allowed <= 2
    for j in range(k):
        unambiguous &= per_leg[j] <= 1
    return unambiguous


@numba.njit(cache=True)
def correct_in_place(position, velocity, covariance, z, use, measurement_variance):  # pragma: no cover
    """The Kalman correction of the points with ``use[i]`` by the positions ``z`` (n, dim)."""
    for i in range(position.shape[0]):
        if not use[i]:
            continue
        p00, p01, p10 = covariance[i, 0, 0], covariance[i, 0, 1], covariance[i, 1, 0]
        s = p00 + measurement_variance
        g0, g1 = p00 / s, p10 / s
        for a in range(position.shape[1]):
            innovation = z[i, a] - position[i, a]
            position[i, a] += g0 * innovation
            velocity[i, a] += g1 * innovation
        covariance[i, 0, 0] -= g0 * p00
        covariance[i, 0, 1] -= g0 * p01
        covariance[i, 1, 0] -= g1 * p00
        covariance[i, 1, 1] -= g1 * p01
