"""Compiled ``cobotsafety.projection.slide``: the same dual active-set algorithm, step by step.

``projection.py`` is the spec (Goldfarb & Idnani's dual method for an identity Hessian, a fine
pass at 1e-12 and a coarse one at 1e-9 relative to the largest violation, a polish of the
active set's equations); this module repeats its arithmetic without Python's per-call cost.
``status``: 0 solved, 1 infeasible (the reference raises ``InfeasibleConstraintsError``).
"""

from __future__ import annotations

import numba
import numpy as np

FEASIBILITY_TOLERANCE = 1e-9


@numba.njit(cache=True)
def _submatrix(K, idx):  # pragma: no cover - compiled
    """``K[idx][:, idx]`` (the active set's Gram matrix) as a fresh contiguous array."""
    n = idx.size
    out = np.empty((n, n))
    for a in range(n):
        for b in range(n):
            out[a, b] = K[idx[a], idx[b]]
    return out


@numba.njit(cache=True)
def _dual_active_set(G, h, tol: float):  # pragma: no cover - compiled
    m, n = G.shape
    K = G @ G.T
    slack = -h
    lam = np.zeros(m)
    active = np.empty(m + 1, dtype=np.int64)
    na = 0
    for _ in range(10 * (m + n) + 10):
        p = int(np.argmin(slack))
        if slack[p] >= -tol:
            if na > 0:
                idx = active[:na]
                lam_A = np.linalg.solve(_submatrix(K, idx), h[idx])
                if np.all(lam_A >= 0.0):
                    return G[idx].T @ lam_A, 0
            return G.T @ lam, 0
        while True:
            K_p = K[p]
            if na > 0:
                idx = active[:na]
                K_AA = _submatrix(K, idx)
                if na > 1:
                    r = np.linalg.solve(K_AA, K_p[idx])
                else:
                    r = K_p[idx] / K_AA[0, 0]
                direction = K_p - r @ K[idx]
                zz = direction[p]
                lam_A = lam[idx]
                drop = 0
                t_partial = np.inf
                for a in range(na):
                    ratio = lam_A[a] / r[a] if r[a] > 1e-15 else np.inf
                    if ratio < t_partial:
                        t_partial, drop = ratio, a
            else:
                direction = K_p.copy()
                zz = K_p[p]
                t_partial = np.inf
                drop = 0
                r = np.zeros(0)
                lam_A = np.zeros(0)
            t_full = -slack[p] / zz if zz > 1e-12 else np.inf
            t = min(t_full, t_partial)
            if t == np.inf:
                return np.zeros(n), 1
            slack = slack + t * direction
            for a in range(na):
                lam[active[a]] = lam_A[a] - t * r[a]
            lam[p] += t
            if t_full <= t_partial:
                active[na] = p
                na += 1
                break
            lam[active[drop]] = 0.0
            for a in range(drop, na - 1):
                active[a] = active[a + 1]
            na -= 1
    return np.zeros(n), 1


@numba.njit(cache=True)
def slide_kernel(v, N, b):  # pragma: no cover - compiled
    """``(slide(v, N, b), status, advance)``; ``N`` (m, n), ``b`` (m,), everything finite.
    status 1: infeasible (``advance``: the largest required advance of the normalised rows, as
    the reference's message says); 3: a zero normal with a positive bound."""
    m, n = N.shape
    if m == 0:
        return v.copy(), 0, 0.0
    h = b - N @ v
    if np.all(h <= FEASIBILITY_TOLERANCE):
        return v.copy(), 0, 0.0
    G = np.empty((m, n))
    hs = np.empty(m)
    for i in range(m):
        s = 0.0
        for k in range(n):
            s += N[i, k] * N[i, k]
        scale = np.sqrt(s)
        if scale == 0.0:
            if h[i] > FEASIBILITY_TOLERANCE:
                return np.zeros(n), 3, 0.0
            G[i] = N[i]
            hs[i] = -np.inf
        else:
            for k in range(n):
                G[i, k] = N[i, k] / scale
            hs[i] = h[i] / scale
    advance = np.max(hs)
    scale_h = max(1.0, advance)
    x, status = _dual_active_set(G, hs, 1e-12 * scale_h)
    if status != 0:
        x, status = _dual_active_set(G, hs, FEASIBILITY_TOLERANCE * scale_h)
    if status != 0:
        return np.zeros(n), 1, advance
    return v + x, 0, advance


RELAX_DONE, RELAX_HARD_CONTRADICT, RELAX_STAGE_INFEASIBLE, RELAX_ILL_CONDITIONED, RELAX_OTHER = 0, 1, 2, 3, 4


@numba.njit(cache=True)
def relax_kernel(v, N, b, soft, floors, weight: float):  # pragma: no cover - compiled
    """``(projection.relax(v, N, b, soft, floors), violation (m,), status, rows, advance)``: the
    same two stages (least-squares violation of the soft rows, each slack capped at
    ``b - floor``, then ``slide`` with their bounds lowered) and the same final check; ``floors``
    (m,) with -inf for none. ``status`` says which ``InfeasibleConstraintsError`` the reference
    raises: ``RELAX_HARD_CONTRADICT`` (no soft rows; ``rows`` = m), ``RELAX_STAGE_INFEASIBLE``
    (the least-squares stage's ``slide``: its ``rows`` and largest required ``advance``),
    ``RELAX_ILL_CONDITIONED`` (the final check), ``RELAX_OTHER`` (a zero normal in the stage)."""
    m, n = N.shape
    violation = np.zeros(m)
    x, status, advance = slide_kernel(v, N, b)
    if status == 0:
        return x, violation, RELAX_DONE, 0, 0.0
    if not np.any(soft):
        return x, violation, RELAX_HARD_CONTRADICT, m, 0.0
    soft_index = np.full(m, -1, dtype=np.int64)
    ks = 0
    for i in range(m):
        if soft[i]:
            soft_index[i] = ks
            ks += 1
    capped = np.empty(m, dtype=np.int64)  # row indices of the soft rows with a floor
    nc = 0
    for i in range(m):
        if soft[i] and np.isfinite(floors[i]):
            capped[nc] = i
            nc += 1
    G = np.zeros((m + nc, n + ks))
    h = np.empty(m + nc)
    for i in range(m):
        for j in range(n):
            G[i, j] = N[i, j] / weight
        if soft[i]:
            G[i, n + soft_index[i]] = 1.0
        h[i] = b[i]
    for c in range(nc):
        G[m + c, n + soft_index[capped[c]]] = -1.0
        h[m + c] = floors[capped[c]] - b[capped[c]]
    x, status, advance = slide_kernel(np.zeros(n + ks), G, h)
    if status != 0:
        return x[:n], violation, RELAX_STAGE_INFEASIBLE if status == 1 else RELAX_OTHER, m + nc, advance
    v_least = x[:n] / weight
    lowered = b.copy()
    for i in range(m):
        if soft[i]:
            s = 0.0
            for j in range(n):
                s += N[i, j] * v_least[j]
            violation[i] = max(b[i] - s, 0.0)
            lowered[i] = b[i] - violation[i]
    x, status, advance = slide_kernel(v, N, lowered)
    if status != 0:
        x = v_least
    # Never a command that breaks a hard row or a floor (an ill-conditioned stage).
    rates = N @ x
    for i in range(m):
        if rates[i] < b[i] - violation[i] - 1e-6 * max(1.0, abs(b[i])):
            return x, violation, RELAX_ILL_CONDITIONED, 0, 0.0
        if soft[i] and np.isfinite(floors[i]) and rates[i] < floors[i] - 1e-6 * max(1.0, abs(floors[i])):
            return x, violation, RELAX_ILL_CONDITIONED, 0, 0.0
    return x, violation, RELAX_DONE, 0, 0.0
