"""The one projection: the point closest to a given one inside a polyhedron, compiled.

Every filter of the package reduces to a *least-distance problem*::

    min ||x||   subject to   G x >= h

(``slide``: ``x = v - v_desired``; the arm's joint-space filter: ``x`` the weighted change of
the command). It is solved by Goldfarb & Idnani's dual active-set method (1983) specialised to
an identity Hessian, in primal form: start from the unconstrained optimum ``x = 0``, add the
most violated row, step along the part of its normal orthogonal to the active rows until it is
tight, dropping an active row whose multiplier reaches zero on the way. The active normals stay
linearly independent, so each small solve (at most ``n`` active rows) is well posed. Each step
costs ``O(m n)`` (one pass over the rows) plus a Cholesky factorisation of the active rows'
Gram matrix (at most ``n x n``).

Rows are scaled to unit length first (their largest entry, then their norm: no overflow for
finite rows of any size); a fine pass at ``1e-12`` relative to the largest violation, and when
rounding makes it cycle on degenerate problems (many rows through one point), a coarse pass at
``FEASIBILITY_TOLERANCE``; a final polish solves the active set's equations directly.

``relax_kernel`` adds the least-squares relaxation of ``soft`` rows when the rows contradict
each other (``cobotsafety.projection.relax`` documents it). The Python source is the
specification: with ``NUMBA_DISABLE_JIT=1`` it runs as written.
"""

from __future__ import annotations

import numba
import numpy as np

#: Constraint violations below this (relative to the problem's scale) count as satisfied.
FEASIBILITY_TOLERANCE = 1e-9
#: Status codes of ``slide_kernel`` and ``relax_kernel``.
SOLVED, INFEASIBLE, ZERO_ROW_INFEASIBLE, NOT_MET = 0, 1, 3, 5
RELAX_DONE, RELAX_HARD_CONTRADICT, RELAX_STAGE_INFEASIBLE, RELAX_ILL_CONDITIONED, RELAX_OTHER = 0, 1, 2, 3, 4
#: Weight of the command in the violation stage of ``relax_kernel`` [-] (see ``projection.relax``).
RELAXATION_COMMAND_WEIGHT = 1e-2


@numba.njit(cache=True)
def _factor_rows(K, L, start, na):  # pragma: no cover - compiled (runs as Python without JIT)
    """Rows ``start..na-1`` of the Cholesky factor ``L`` of ``K[:na, :na]`` (symmetric positive
    definite; the rows above ``start`` are kept: row ``i`` depends on rows ``<= i`` only).
    False when a pivot is not positive (dependent rows)."""
    for i in range(start, na):
        for j in range(i + 1):
            s = K[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if s <= 1e-300:
                    return False
                L[i, i] = np.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    return True


@numba.njit(cache=True)
def _solve_factor(L, na, rhs, y):  # pragma: no cover - compiled
    """``y[:na]`` with ``L L^T y = rhs[:na]`` (forward, then back substitution, in place)."""
    for i in range(na):
        s = rhs[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(na - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, na):
            s -= L[k, i] * y[k]
        y[i] = s / L[i, i]


@numba.njit(cache=True)
def _direction(G, active, na, p, L, z, r, dots):  # pragma: no cover - compiled
    """The primal step ``z`` (n,): row ``p``'s normal minus its part in the active rows' span,
    the multipliers' rates ``r`` (na,) (``g_p = G_A^T r + z``) and row ``p``'s products with the
    active rows ``dots`` (na,), from the Cholesky factor ``L`` of the active rows' Gram matrix.
    Returns ``||z||^2``."""
    n = G.shape[1]
    for k in range(n):
        z[k] = G[p, k]
    for a in range(na):
        ia = active[a]
        s = 0.0
        for k in range(n):
            s += G[ia, k] * G[p, k]
        dots[a] = s
    _solve_factor(L, na, dots, r)
    for a in range(na):
        ia = active[a]
        for k in range(n):
            z[k] -= r[a] * G[ia, k]
    s = 0.0
    for k in range(n):
        s += z[k] * z[k]
    return s


@numba.njit(cache=True)
def _dual_active_set(G, h, tol):  # pragma: no cover - compiled
    """``argmin ||x|| s.t. G x >= h`` for unit rows ``G`` (m, n): ``(x, ok)``; ``ok`` False
    when the rows contradict each other (or the active set degenerated).

    The active rows' Gram matrix ``K`` is kept (a row entering adds the products its step
    computed) and so is its Cholesky factor ``L``: rows ``< factored`` are valid, a row entering
    adds one, a row leaving invalidates the rows from its place on."""
    m, n = G.shape
    x = np.zeros(n)
    lam = np.zeros(m)
    active = np.empty(n + 1, dtype=np.int64)
    na = 0
    factored = 0
    K = np.empty((n + 1, n + 1))
    L = np.empty((n + 1, n + 1))
    z = np.empty(n)
    r = np.empty(n + 1)
    dots = np.empty(n + 1)
    slack = np.empty(m)
    for _ in range(10 * (m + n) + 10):
        p = -1
        worst = -tol
        for i in range(m):
            s = -h[i]
            for k in range(n):
                s += G[i, k] * x[k]
            slack[i] = s
            if s < worst:
                worst, p = s, i
        if p < 0:
            if na > 0:
                # Polish: the active rows' equations solved directly (no accumulated rounding).
                y = np.empty(na)
                for a in range(na):
                    dots[a] = h[active[a]]
                ok = factored == na or _factor_rows(K, L, factored, na)
                if ok:
                    _solve_factor(L, na, dots, y)
                if ok and np.all(y >= 0.0):
                    polished = np.zeros(n)
                    for a in range(na):
                        for k in range(n):
                            polished[k] += y[a] * G[active[a], k]
                    for i in range(m):
                        s = -h[i]
                        for k in range(n):
                            s += G[i, k] * polished[k]
                        if s < -tol:
                            ok = False
                            break
                    if ok:
                        return polished, True
            return x, True
        s_p = slack[p]
        while True:
            if factored < na:
                if not _factor_rows(K, L, factored, na):
                    return x, False
                factored = na
            zz = _direction(G, active, na, p, L, z, r, dots)
            # n active rows span every direction: row p is in their span (its ``z`` is rounding
            # only) and takes a partial step; a full one would add an (n+1)-th active row.
            t_full = -s_p / zz if zz > 1e-24 and na < n else np.inf
            t_partial = np.inf
            drop = -1
            for a in range(na):
                if r[a] > 1e-15:
                    ratio = lam[active[a]] / r[a]
                    if ratio < t_partial:
                        t_partial, drop = ratio, a
            t = min(t_full, t_partial)
            if t == np.inf:
                return x, False
            for k in range(n):
                x[k] += t * z[k]
            for a in range(na):
                lam[active[a]] -= t * r[a]
            lam[p] += t
            s_p += t * zz
            if t_full <= t_partial:
                # Row p enters: its products with the active rows (``dots``) and with itself
                # complete the Gram matrix; its factor row is computed when next needed.
                for b in range(na):
                    K[na, b] = dots[b]
                    K[b, na] = dots[b]
                s = 0.0
                for k in range(n):
                    s += G[p, k] * G[p, k]
                K[na, na] = s
                active[na] = p
                na += 1
                break
            lam[active[drop]] = 0.0
            for a in range(drop, na - 1):
                active[a] = active[a + 1]
                for b in range(na):
                    K[a, b] = K[a + 1, b]
            for b in range(drop, na - 1):
                for a in range(na - 1):
                    K[a, b] = K[a, b + 1]
            na -= 1
            factored = min(factored, drop)
    return x, False


@numba.njit(cache=True)
def slide_kernel(v, N, b):  # pragma: no cover - compiled
    """``(x, status, advance)``: the ``x`` closest to ``v`` (n,) with ``N @ x >= b`` (N (m, n),
    b (m,), all finite). ``status``: ``SOLVED``; ``INFEASIBLE`` (the rows contradict each
    other; ``advance`` is the largest violation of the unit rows at ``v``, as the error says);
    ``ZERO_ROW_INFEASIBLE`` (a zero row with a positive bound); ``NOT_MET`` (the answer
    misses a row by more than the tolerance: rounding on an ill-conditioned problem). A bound
    of -inf makes its row inactive.

    Overflow-safe: each row is divided by its largest entry and then by its norm (its bound
    too), and when ``v`` or those unit rows' positive bounds are huge (> 1e100) the problem is
    solved scaled down (the projection is positively homogeneous in ``(v, b)``); a positive
    bound beyond float range once its row is scaled gives ``NOT_MET`` (a negative one: the row
    is met by any representable answer).
    """
    m, n = N.shape
    if m == 0:
        return v.copy(), SOLVED, 0.0
    # The problem's size in the command's unit: the command and the positive bounds of the
    # rows scaled to unit length (rows of 1e200 with bounds of 1e200 ask for O(1), not 1e200;
    # a negative bound is met by the origin and cannot make the answer larger than ``v``).
    G = np.empty((m, n))
    h = np.empty(m)
    bound = np.empty(m)  # the unit rows' bounds
    zero = np.zeros(m, dtype=np.bool_)  # inactive rows (-inf) and zero rows
    size = 1.0
    for k in range(n):
        size = max(size, abs(v[k]))
    for i in range(m):
        largest = 0.0
        for k in range(n):
            largest = max(largest, abs(N[i, k]))
        if b[i] == -np.inf or largest == 0.0:
            zero[i] = True
            for k in range(n):
                G[i, k] = 0.0
            continue
        norm2 = 0.0
        for k in range(n):
            G[i, k] = N[i, k] / largest
            norm2 += G[i, k] * G[i, k]
        norm = np.sqrt(norm2)
        for k in range(n):
            G[i, k] /= norm
        bound[i] = b[i] / largest / norm
        if bound[i] == np.inf:  # a bound beyond float range for its row: no answer to give
            return v.copy(), NOT_MET, np.inf
        size = max(size, bound[i])
    scale = size if size > 1e100 else 1.0
    vs = v / scale
    any_violated = False
    for i in range(m):
        if zero[i]:
            if b[i] / scale > FEASIBILITY_TOLERANCE:
                return np.zeros(n), ZERO_ROW_INFEASIBLE, 0.0
            h[i] = -np.inf
            continue
        bound[i] /= scale
        rate = 0.0
        for k in range(n):
            rate += G[i, k] * vs[k]
        h[i] = bound[i] - rate
        if h[i] > FEASIBILITY_TOLERANCE:
            any_violated = True
    if not any_violated:
        return v.copy(), SOLVED, 0.0
    advance = -np.inf
    for i in range(m):
        advance = max(advance, h[i])
    scale_h = max(1.0, advance)
    x, ok = _dual_active_set(G, h, 1e-12 * scale_h)
    if not ok:
        x, ok = _dual_active_set(G, h, FEASIBILITY_TOLERANCE * scale_h)
    if not ok:
        return np.zeros(n), INFEASIBLE, advance * scale
    result = (vs + x) * scale
    # The answer is checked before it is handed out: every row met to the tolerance.
    for i in range(m):
        if h[i] == -np.inf:
            continue
        gap = 0.0
        for k in range(n):
            gap += G[i, k] * (vs[k] + x[k])
        if gap < bound[i] - 1e3 * FEASIBILITY_TOLERANCE * scale_h:
            return result, NOT_MET, advance
    for k in range(n):
        if not np.isfinite(result[k]):
            return result, NOT_MET, advance
    return result, SOLVED, advance


@numba.njit(cache=True)
def relax_kernel(v, N, b, soft, floors, weight):  # pragma: no cover - compiled
    """``(x (n,), violation (m,), status, rows, advance)``: ``slide_kernel`` when the rows agree;
    otherwise the ``soft`` rows give way by least squares (each at most down to ``floors``,
    -inf for none) while the others stay hard, then the slide onto the relaxed rows
    (``cobotsafety.projection.relax`` documents the two stages). ``status``: ``RELAX_DONE``;
    ``RELAX_HARD_CONTRADICT`` (nothing soft: ``rows`` = m); ``RELAX_STAGE_INFEASIBLE`` (the
    hard rows and floors contradict: its ``rows`` and largest required ``advance``);
    ``RELAX_ILL_CONDITIONED`` (the answer misses a hard row or a floor); ``RELAX_OTHER`` (a
    zero row with a positive bound in the stage)."""
    m, n = N.shape
    violation = np.zeros(m)
    x, status, advance = slide_kernel(v, N, b)
    if status == SOLVED:
        return x, violation, RELAX_DONE, 0, 0.0
    if not np.any(soft):
        return x, violation, RELAX_HARD_CONTRADICT, m, 0.0
    soft_index = np.full(m, -1, dtype=np.int64)
    ks = 0
    for i in range(m):
        if soft[i]:
            soft_index[i] = ks
            ks += 1
    capped = np.empty(m, dtype=np.int64)
    nc = 0
    for i in range(m):
        if soft[i] and np.isfinite(floors[i]):
            capped[nc] = i
            nc += 1
    # Stage 1 as a least-distance problem in (w v, s): the hard rows on w v, the soft rows on
    # (w v, s), each floor a cap on its slack, s_i <= b_i - floor_i.
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
    y, status, advance = slide_kernel(np.zeros(n + ks), G, h)
    if status != SOLVED:
        return y[:n], violation, RELAX_STAGE_INFEASIBLE if status == INFEASIBLE else RELAX_OTHER, m + nc, advance
    v_least = y[:n] / weight
    lowered = b.copy()
    for i in range(m):
        if soft[i]:
            s = 0.0
            for j in range(n):
                s += N[i, j] * v_least[j]
            violation[i] = max(b[i] - s, 0.0)
            lowered[i] = b[i] - violation[i]
    x, status, _ = slide_kernel(v, N, lowered)
    if status != SOLVED:
        x = v_least  # rounding at the relaxed bounds: the stage's command meets them
    # Never a command that breaks a hard row or a floor (an ill-conditioned stage).
    for i in range(m):
        s = 0.0
        for j in range(n):
            s += N[i, j] * x[j]
        if s < b[i] - violation[i] - 1e-6 * max(1.0, abs(b[i])):
            return x, violation, RELAX_ILL_CONDITIONED, 0, 0.0
        if soft[i] and np.isfinite(floors[i]) and s < floors[i] - 1e-6 * max(1.0, abs(floors[i])):
            return x, violation, RELAX_ILL_CONDITIONED, 0, 0.0
    return x, violation, RELAX_DONE, 0, 0.0
