"""The user's task in joint space: what joint velocity would follow the hand's command.

The command is the end-effector's translational velocity ``v`` [m/s]. Its joint-space
solution is ``qdot = M v + c``:

* ``M = J^+``, the damped pseudo-inverse of the translation Jacobian ``J`` (3, nv) (paper 2,
  eq. 16), its damping growing smoothly as the manipulability ``w = sqrt(det(J J^T))`` falls
  below ``w_threshold`` (the singularity safeguard: near a singularity the command shrinks
  smoothly and motion away from it stays available);
* ``c``: a secondary task in the translation's null space that holds the home orientation and,
  on redundant arms, pulls joints toward the middle of their range, never more than half of any
  joint's speed limit.

The filter keeps the arm's redundancy free: ``Z`` (nv, nv - 3) is an orthonormal basis of the
null space of ``J`` (the body's motions that do not move the hand), so that a limitation on the
body can be met by moving the body rather than the hand (``joint_filter``).
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.small_linalg import matmul, matmul_nt, matmul_tn, matvec, matvec_t


@numba.njit(cache=True)
def det_psd(A):  # pragma: no cover - compiled
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
def inverse_spd(A):  # pragma: no cover - compiled
    """Inverse of a small symmetric positive definite matrix (Gauss-Jordan, no pivoting)."""
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
def damped_least_squares(J, v, damping):  # pragma: no cover - compiled
    """``J^T (J J^T + damping I)^-1 v`` (paper 2, eqs. 16 and 20: ``damping`` is their lambda,
    added to the diagonal as written): (nv,)."""
    JJt = matmul_nt(J, J)
    for i in range(JJt.shape[0]):
        JJt[i, i] += damping
    return matvec_t(J, matvec(inverse_spd(JJt), v))


@numba.njit(cache=True)
def null_basis(J):  # pragma: no cover - compiled
    """An orthonormal basis (nv, nv - k) of the null space of ``J`` (k, nv), from the
    Householder QR factorisation of ``J^T``: its last ``nv - k`` columns of ``Q``."""
    k, nv = J.shape
    Q = np.eye(nv)
    R = J.T.copy()
    for col in range(k):
        x = R[col:, col].copy()
        alpha = np.sqrt(np.sum(x * x))
        if alpha == 0.0:
            continue
        if x[0] > 0.0:
            alpha = -alpha
        x[0] -= alpha
        norm = np.sqrt(np.sum(x * x))
        if norm == 0.0:
            continue
        x /= norm
        # R <- (I - 2 x x^T) R on the rows col:, Q <- Q (I - 2 x x^T) on the columns col:.
        for j in range(k):
            s = 0.0
            for i in range(nv - col):
                s += x[i] * R[col + i, j]
            for i in range(nv - col):
                R[col + i, j] -= 2.0 * x[i] * s
        for i in range(nv):
            s = 0.0
            for j in range(nv - col):
                s += Q[i, col + j] * x[j]
            for j in range(nv - col):
                Q[i, col + j] -= 2.0 * s * x[j]
    return np.ascontiguousarray(Q[:, k:])


@numba.njit(cache=True)
def task_mapping(J, J_angular, error_rad, centering, damping_max, w_threshold, orientation_gain_per_s,
                 half_velocity_limit, with_orientation):  # pragma: no cover - compiled
    """``(M (nv, k), c (nv,))``: the damped pseudo-inverse of ``J`` (k, nv) and the secondary
    term. ``centering`` (nv,) is the joint-centring secondary velocity; with
    ``with_orientation`` the rotation error ``error_rad`` (3,) is corrected at
    ``orientation_gain_per_s`` through the damped least squares of ``J_angular`` restricted to
    the null space."""
    k, nv = J.shape
    JJt = matmul_nt(J, J)
    w = np.sqrt(max(det_psd(JJt), 0.0))
    lam2 = damping_max ** 2 * (1.0 - w / w_threshold) ** 2 if w < w_threshold else 0.0
    for i in range(k):
        JJt[i, i] += lam2
    M = matmul_tn(J, inverse_spd(JJt))
    N = np.eye(nv) - matmul(M, J)
    secondary = centering.copy()
    if with_orientation:
        JwN = matmul(J_angular, N)
        B = matmul_nt(JwN, JwN)
        for i in range(3):
            B[i, i] += 0.01
        secondary += matvec_t(JwN, matvec(inverse_spd(B), orientation_gain_per_s * error_rad))
    c = matvec(N, secondary)
    ratio = 0.0
    for i in range(nv):
        ratio = max(ratio, abs(c[i]) / half_velocity_limit[i])
    if ratio > 1.0:
        c = c / ratio
    return M, c
