"""The sliding projection: the closest velocity to the desired one that satisfies every half-space.

This is paper 1's sliding rule (eq. 1) generalised as its erratum 3 says: with one active
constraint it removes the command's component against the constraint's normal; with several it
is the minimum-norm change of the command that satisfies all of them (a projection onto a convex
polyhedron), which in 2D agrees with the paper's rule of section III.A.
"""

from __future__ import annotations

import logging

import numpy as np

from cobotsafety.errors import InfeasibleConstraintsError

logger = logging.getLogger(__name__)

#: Constraint violations below this [same unit as ``bounds``] count as satisfied.
FEASIBILITY_TOLERANCE = 1e-9


def _as_inputs(v_desired, normals, bounds) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    v = np.asarray(v_desired, dtype=float)
    if v.ndim != 1:
        raise ValueError(f"v_desired must have shape (n,), got {v.shape}")
    n = v.shape[0]
    N = np.asarray(normals, dtype=float)
    if N.size == 0:
        N = N.reshape(0, n)
    if N.ndim != 2 or N.shape[1] != n:
        raise ValueError(f"normals must have shape (m, {n}) to match v_desired, got {N.shape}")
    m = N.shape[0]
    if bounds is None:
        b = np.zeros(m)
    else:
        b = np.asarray(bounds, dtype=float)
        if b.size == 0 and m == 0:
            b = b.reshape(0)
        if b.shape != (m,):
            raise ValueError(f"bounds must have shape ({m},) to match normals, got {b.shape}")
    if not np.all(np.isfinite(N)):
        raise ValueError("normals contains NaN or inf")
    if not np.all(np.isfinite(b)):
        raise ValueError("bounds contains NaN or inf")
    return v, N, b


def slide(v_desired, normals, bounds=None) -> np.ndarray:
    """Return the velocity closest to ``v_desired`` with ``normals @ v >= bounds``.

    Solves ``min ||v - v_desired||  s.t.  normals @ v >= bounds`` exactly (a least-distance
    problem, solved through its non-negative least-squares dual, Lawson & Hanson ch. 23;
    scipy's ``nnls`` is not used: version 1.17 returns wrong answers on some of these problems).

    Args:
        v_desired: Shape (n,). The desired velocity (any unit; the bounds share it).
        normals: Shape (m, n). One half-space normal per row, pointing into the allowed side.
            They need not be unit vectors. m = 0 returns a copy of ``v_desired``.
        bounds: Shape (m,), or None for zeros. ``bounds[i] <= 0`` always admits v = 0.

    Returns:
        Shape (n,), a new array. When ``v_desired`` already satisfies every half-space it is
        returned unchanged (as a copy).

    Raises:
        ValueError: a wrong shape (the message names the argument), or NaN/inf in
            ``normals`` or ``bounds``.
        InfeasibleConstraintsError: no v satisfies all half-spaces (e.g. ``n @ v >= 1`` and
            ``-n @ v >= 1``). Nothing is returned in that case: the caller decides (the filter
            stops the robot).

    A ``v_desired`` holding NaN or inf is treated as "no command": a warning is logged and the
    result is the projection of the zero vector (the zero vector itself when all bounds <= 0).
    """
    v, N, b = _as_inputs(v_desired, normals, bounds)
    if not np.all(np.isfinite(v)):
        logger.warning("v_desired contains NaN or inf (%s); commanding zero instead", v)
        v = np.zeros_like(v)
    if N.shape[0] == 0:
        return v.copy()
    # h: how much each constraint is violated at v_desired (positive = violated).
    h = b - N @ v
    if np.all(h <= FEASIBILITY_TOLERANCE):
        return v.copy()
    return v + _least_distance(N, h)


#: Weight of the command in the violation stage of ``relax`` [-]: among the commands that
#: violate the soft rows least, the smallest; an extra 1 m/s of command weighs as much as
#: 0.01 m/s of violation, so the violation found is within ~1e-4 m/s of the exact minimum.
RELAXATION_COMMAND_WEIGHT = 1e-2


def relax(v_desired, normals, bounds, soft, floor=None) -> tuple[np.ndarray, np.ndarray]:
    """``slide`` when it can; when the half-spaces contradict each other, violate the ``soft``
    rows as little as possible (least squares) while every other row stays hard.

    Two stages (a lexicographic relaxation):

    1. ``s* = argmin ||s||^2 + w^2 ||v||^2`` over ``(v, s)`` subject to
       ``normals[hard] @ v >= bounds[hard]``, ``normals[soft] @ v + s >= bounds[soft]`` and
       ``normals[soft] @ v >= floor[soft]`` (``w = RELAXATION_COMMAND_WEIGHT``; ``s*`` is the
       least-squares violation);
    2. the command closest to ``v_desired`` with the soft bounds lowered by ``s*``:
       ``slide(v_desired, normals, bounds - s*)``.

    Args:
        v_desired: Shape (n,).
        normals: Shape (m, n).
        bounds: Shape (m,).
        soft: Shape (m,) bool, the rows that may give way.
        floor: Shape (m,) or None (no floor): the soft rows give way down to this bound at
            most (a hard row ``normals @ v >= floor``; ``0``: "approach nothing"). The hard rows
            and the floors must admit a common command (e.g. all <= 0: ``v = 0``).

    Returns:
        ``(v (n,), violation (m,))``: the command and how much each row's bound was lowered
        (zero for the hard rows, and for all rows when ``slide`` alone succeeded).

    Raises:
        ValueError: wrong shapes or non-finite inputs (as ``slide``).
        InfeasibleConstraintsError: the hard rows alone contradict each other (or the active
            set degenerated on dependent rows).
    """
    v, N, b = _as_inputs(v_desired, normals, bounds)
    soft = np.asarray(soft, dtype=bool).reshape(-1)
    if soft.shape != b.shape:
        raise ValueError(f"soft must have shape {b.shape} to match bounds, got {soft.shape}")
    violation = np.zeros_like(b)
    try:
        return slide(v, N, b), violation
    except (InfeasibleConstraintsError, np.linalg.LinAlgError):  # degenerate rows count as contradicting
        if not np.any(soft):
            raise InfeasibleConstraintsError(f"the {N.shape[0]} hard half-spaces contradict each other") from None
    floors = np.full_like(b, -np.inf) if floor is None else np.broadcast_to(np.asarray(floor, dtype=float), b.shape)
    if np.any(np.isnan(floors)):
        raise ValueError("floor contains NaN")
    n, k = N.shape[1], int(soft.sum())
    soft_rows = np.flatnonzero(soft)
    capped = np.flatnonzero(np.isfinite(floors[soft_rows]))  # positions among the soft rows
    # Stage 1 as a least-distance problem in x = (w v, s): the hard rows on w v, the soft rows
    # on (w v, s), and each floor as a cap on its slack, s_i <= b_i - floor_i (which with
    # N_i v + s_i >= b_i gives N_i v >= floor_i, and keeps the rows well conditioned).
    G = np.zeros((N.shape[0] + capped.size, n + k))
    G[:N.shape[0], :n] = N / RELAXATION_COMMAND_WEIGHT
    G[soft_rows, n + np.arange(k)] = 1.0
    G[N.shape[0] + np.arange(capped.size), n + capped] = -1.0
    h = np.concatenate([b, floors[soft_rows[capped]] - b[soft_rows[capped]]])
    try:
        x = slide(np.zeros(n + k), G, h)
    except np.linalg.LinAlgError:
        raise InfeasibleConstraintsError("the relaxation's active set degenerated (dependent rows)") from None
    v_least = x[:n] / RELAXATION_COMMAND_WEIGHT
    violation[soft] = np.maximum(b[soft] - N[soft] @ v_least, 0.0)
    try:
        v_relaxed = slide(v, N, b - violation)
    except (InfeasibleConstraintsError, np.linalg.LinAlgError):  # rounding at the relaxed bounds
        v_relaxed = v_least  # which satisfies them
    # Never hand out a command that breaks a hard row or a floor (an ill-conditioned stage).
    scale = np.maximum(1.0, np.abs(b))
    floor_ok = ~np.isfinite(floors) | ~soft | (N @ v_relaxed >= floors - 1e-6 * np.maximum(1.0, np.abs(floors)))
    if np.any((N @ v_relaxed < b - violation - 1e-6 * scale)) or not np.all(floor_ok):
        raise InfeasibleConstraintsError("the relaxation did not meet its hard rows (ill-conditioned rows)")
    return v_relaxed, violation


def _least_distance(G: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Return argmin ||x|| subject to G x >= h.

    Goldfarb & Idnani's dual active-set method (1983) for an identity Hessian: start from the
    unconstrained optimum x = 0, add the most violated constraint, take the step that makes it
    tight while keeping the others' multipliers non-negative, drop a constraint whose multiplier
    reaches zero. The active normals stay linearly independent, so each solve is well posed.
    """
    m, n = G.shape
    scale = np.linalg.norm(G, axis=1)
    bad = (scale == 0.0) & (h > FEASIBILITY_TOLERANCE)
    if np.any(bad):
        raise InfeasibleConstraintsError(
            f"constraint(s) {np.flatnonzero(bad).tolist()} have a zero normal and a positive "
            "bound: 0 >= bound can never hold"
        )
    safe_scale = np.where(scale == 0.0, 1.0, scale)
    G = G / safe_scale[:, None]
    h = np.where(scale == 0.0, -np.inf, h / safe_scale)
    # Tolerances relative to the largest violation, so a far-away inactive row cannot loosen
    # them. The fine pass is exact to rounding; on degenerate (many rows through one point)
    # problems rounding can make it cycle, and the coarse pass (1e-9) settles those.
    scale_h = max(1.0, float(np.max(h)))
    try:
        return _dual_active_set(G, h, 1e-12 * scale_h)
    except InfeasibleConstraintsError:
        return _dual_active_set(G, h, FEASIBILITY_TOLERANCE * scale_h)


def _dual_active_set(G: np.ndarray, h: np.ndarray, tol: float) -> np.ndarray:
    m, n = G.shape
    # Work in the dual: x = G^T lam, slack = K lam - h with the Gram matrix K = G G^T.
    K = G @ G.T
    slack = -h
    lam = np.zeros(m)
    active: list[int] = []
    for _ in range(10 * (m + n) + 10):
        p = int(slack.argmin())
        if slack[p] >= -tol:
            if active:
                # Polish: solve the active set's equations directly (removes the rounding
                # the incremental slack updates accumulated).
                lam_A = np.linalg.solve(K[np.ix_(active, active)], h[active])
                if np.all(lam_A >= 0.0):
                    return G[active].T @ lam_A
            return G.T @ lam
        while True:
            K_p = K[p]
            if active:
                K_AA = K[np.ix_(active, active)]
                r = np.linalg.solve(K_AA, K_p[active]) if len(active) > 1 else K_p[active] / K_AA[0, 0]
                # Change of every slack per unit step: K (e_p - sum_A r_j e_j).
                direction = K_p - r @ K[active]
                zz = float(direction[p])
                lam_A = lam[active]
                positive = r > 1e-15
                ratios = np.where(positive, lam_A / np.where(positive, r, 1.0), np.inf)
                drop = int(ratios.argmin())
                t_partial = float(ratios[drop])
            else:
                direction = K_p
                zz = float(K_p[p])
                t_partial = np.inf
            t_full = -float(slack[p]) / zz if zz > 1e-12 else np.inf
            t = min(t_full, t_partial)
            if t == np.inf:
                raise InfeasibleConstraintsError(_infeasible_message(G, h))
            slack = slack + t * direction
            if active:
                lam[active] = lam_A - t * r
            lam[p] += t
            if t_full <= t_partial:
                active.append(p)
                break
            lam[active[drop]] = 0.0
            del active[drop]
    raise InfeasibleConstraintsError(_infeasible_message(G, h))


def _infeasible_message(G: np.ndarray, h: np.ndarray) -> str:
    return (
        f"no velocity satisfies the {G.shape[0]} half-spaces at once "
        f"(largest required advance {np.max(h):.3g}); the bounds contradict each other"
    )
