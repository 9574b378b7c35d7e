"""The arithmetic of ``cobotsafety.arm.step.mapping`` in one numba-compiled call.

``qdot = M v + c`` needs a 2x2 or 3x3 inverse, a null-space projector and a damped solve for the
orientation task: a dozen numpy and LAPACK calls on tiny matrices, ~190 us of per-call overhead
per step; compiled loops do the same arithmetic in a few microseconds. The maths is described
in ``cobotsafety.arm.step``; this module only computes it.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def det_psd(A: np.ndarray) -> float:  # pragma: no cover - compiled
    """Determinant of a small symmetric positive semi-definite matrix (0 when singular)."""
    k = A.shape[0]
    U = A.copy()
    det = 1.0
    for i in range(k):
        pivot = U[i, i]
        if pivot <= 0.0:
            return 0.0
        det *= pivot
        for r in range(i + 1, k):
            f = U[r, i] / pivot
            for col in range(i, k):
                U[r, col] -= f * U[i, col]
    return det


@numba.njit(cache=True)
def inverse_spd(A: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Inverse of a small symmetric positive definite matrix (Gauss-Jordan, no pivoting needed)."""
    k = A.shape[0]
    U = A.copy()
    inv = np.eye(k)
    for i in range(k):
        pivot = U[i, i]
        for col in range(k):
            U[i, col] /= pivot
            inv[i, col] /= pivot
        for r in range(k):
            if r != i:
                f = U[r, i]
                for col in range(k):
                    U[r, col] -= f * U[i, col]
                    inv[r, col] -= f * inv[i, col]
    return inv


@numba.njit(cache=True)
def mapping_kernel(J: np.ndarray, J_angular: np.ndarray, error_rad: np.ndarray, centering: np.ndarray,
                   damping_max: float, w_threshold: float, orientation_gain_per_s: float,
                   half_velocity_limit: np.ndarray, with_orientation: bool):  # pragma: no cover - compiled
    """``(M (nv, k), c (nv,))``: damped pseudo-inverse of ``J`` (k, nv) and the null-space term.

    ``centering`` (nv,) is the joint-centring secondary velocity; with ``with_orientation`` the
    rotation error ``error_rad`` (3,) is corrected at ``orientation_gain_per_s`` through the
    damped least squares of ``J_angular`` restricted to the null space.
    """
    k, nv = J.shape
    JJt = J @ J.T
    w = np.sqrt(max(det_psd(JJt), 0.0))
    lam2 = damping_max**2 * (1.0 - w / w_threshold) ** 2 if w < w_threshold else 0.0
    for i in range(k):
        JJt[i, i] += lam2
    M = J.T @ inverse_spd(JJt)
    N = np.eye(nv) - M @ J
    secondary = centering.copy()
    if with_orientation:
        JwN = J_angular @ N
        B = JwN @ JwN.T
        for i in range(3):
            B[i, i] += 0.01
        secondary += JwN.T @ (inverse_spd(B) @ (orientation_gain_per_s * error_rad))
    c = N @ secondary
    ratio = 0.0
    for i in range(nv):
        ratio = max(ratio, abs(c[i]) / half_velocity_limit[i])
    if ratio > 1.0:
        c = c / ratio
    return M, c
