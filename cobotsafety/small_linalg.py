"""Products of small dense matrices as plain loops, for the compiled kernels.

numba hands ``A @ B`` on 2D arrays to BLAS, whose call costs ~0.2 us: more than the arithmetic
of the 3x3 to 7x7 products a control step is made of. These loops give the same results (to
rounding) inside one compiled function.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def matmul(A, B):  # pragma: no cover - compiled
    """``A @ B``: (n, k) x (k, m) -> (n, m)."""
    n, k = A.shape
    m = B.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for p in range(k):
            a = A[i, p]
            for j in range(m):
                out[i, j] += a * B[p, j]
    return out


@numba.njit(cache=True)
def matmul_nt(A, B):  # pragma: no cover - compiled
    """``A @ B.T``: (n, k) x (m, k) -> (n, m)."""
    n, k = A.shape
    m = B.shape[0]
    out = np.empty((n, m))
    for i in range(n):
        for j in range(m):
            s = 0.0
            for p in range(k):
                s += A[i, p] * B[j, p]
            out[i, j] = s
    return out


@numba.njit(cache=True)
def matmul_tn(A, B):  # pragma: no cover - compiled
    """``A.T @ B``: (k, n) x (k, m) -> (n, m)."""
    k, n = A.shape
    m = B.shape[1]
    out = np.zeros((n, m))
    for p in range(k):
        for i in range(n):
            a = A[p, i]
            for j in range(m):
                out[i, j] += a * B[p, j]
    return out


@numba.njit(cache=True)
def matvec(A, x):  # pragma: no cover - compiled
    """``A @ x``: (n, k) x (k,) -> (n,)."""
    n, k = A.shape
    out = np.empty(n)
    for i in range(n):
        s = 0.0
        for p in range(k):
            s += A[i, p] * x[p]
        out[i] = s
    return out


@numba.njit(cache=True)
def matvec_t(A, x):  # pragma: no cover - compiled
    """``A.T @ x``: (k, n) x (k,) -> (n,)."""
    k, n = A.shape
    out = np.zeros(n)
    for p in range(k):
        xp = x[p]
        for i in range(n):
            out[i] += A[p, i] * xp
    return out
