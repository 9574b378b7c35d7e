"""The sliding projection: the closest velocity to the desired one that satisfies every half-space.

This is paper 1's sliding rule (eq. 1) generalised as its erratum 3 says: with one active
constraint it removes the command's component against the constraint's normal; with several it
is the minimum-norm change of the command that satisfies all of them (a projection onto a convex
polyhedron), which in 2D agrees with the paper's rule of section III.A.

``slide`` and ``relax`` validate their inputs and call the compiled solver that every filter of
the package runs (``cobotsafety.least_distance``): there is no second implementation.
"""

from __future__ import annotations

import logging

import numpy as np

from cobotsafety.errors import InfeasibleConstraintsError
from cobotsafety.least_distance import (FEASIBILITY_TOLERANCE, INFEASIBLE, NOT_MET, RELAX_DONE,
                                        RELAX_HARD_CONTRADICT, RELAX_ILL_CONDITIONED, RELAX_STAGE_INFEASIBLE,
                                        RELAXATION_COMMAND_WEIGHT, ZERO_ROW_INFEASIBLE, relax_kernel, slide_kernel)

logger = logging.getLogger(__name__)

__all__ = ["FEASIBILITY_TOLERANCE", "RELAXATION_COMMAND_WEIGHT", "relax", "slide"]


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
    return v, np.ascontiguousarray(N), np.ascontiguousarray(b)


def _infeasible_message(rows: int, advance: float) -> str:
    return (f"no velocity satisfies the {rows} half-spaces at once "
            f"(largest required advance {advance:.3g}); the bounds contradict each other")


def slide(v_desired, normals, bounds=None) -> np.ndarray:
    """Return the velocity closest to ``v_desired`` with ``normals @ v >= bounds``.

    Solves ``min ||v - v_desired||  s.t.  normals @ v >= bounds`` exactly: Goldfarb & Idnani's
    dual active-set method specialised to an identity Hessian (``cobotsafety.least_distance``,
    compiled; the same solver as the robot filters).

    Args:
        v_desired: Shape (n,). The desired velocity (any unit; the bounds share it).
        normals: Shape (m, n). One half-space normal per row, pointing into the allowed side.
            They need not be unit vectors: rows are scaled first (no overflow for any finite
            row). m = 0 returns a copy of ``v_desired``.
        bounds: Shape (m,), or None for zeros. ``bounds[i] <= 0`` always admits v = 0.

    Returns:
        Shape (n,), a new array, checked against every row before it is returned. When
        ``v_desired`` already satisfies every half-space it is returned unchanged (as a copy).

    Raises:
        ValueError: a wrong shape (the message names the argument), or NaN/inf in
            ``normals`` or ``bounds``.
        InfeasibleConstraintsError: no v satisfies all half-spaces (e.g. ``n @ v >= 1`` and
            ``-n @ v >= 1``), or (rounding on a degenerate problem) the answer found misses a
            row. Nothing is returned in that case: the caller decides (the filter stops).

    A ``v_desired`` holding NaN or inf is treated as "no command": a warning is logged and the
    result is the projection of the zero vector (the zero vector itself when all bounds <= 0).
    """
    v, N, b = _as_inputs(v_desired, normals, bounds)
    if not np.all(np.isfinite(v)):
        logger.warning("v_desired contains NaN or inf (%s); commanding zero instead", v)
        v = np.zeros_like(v)
    if N.shape[0] == 0:
        return v.copy()
    x, status, advance = slide_kernel(np.ascontiguousarray(v), N, b)
    if status == ZERO_ROW_INFEASIBLE:
        raise InfeasibleConstraintsError("a half-space with a zero normal and a positive bound: 0 >= bound can "
                                         "never hold")
    if status == INFEASIBLE:
        raise InfeasibleConstraintsError(_infeasible_message(N.shape[0], advance))
    if status == NOT_MET:
        raise InfeasibleConstraintsError("the projection found misses a half-space (ill-conditioned rows)")
    return x


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
        InfeasibleConstraintsError: the hard rows alone contradict each other (or the answer
            misses a hard row: ill-conditioned rows).
    """
    v, N, b = _as_inputs(v_desired, normals, bounds)
    soft = np.asarray(soft, dtype=bool).reshape(-1)
    if soft.shape != b.shape:
        raise ValueError(f"soft must have shape {b.shape} to match bounds, got {soft.shape}")
    floors = np.full_like(b, -np.inf) if floor is None else np.broadcast_to(np.asarray(floor, dtype=float), b.shape)
    if np.any(np.isnan(floors)):
        raise ValueError("floor contains NaN")
    if not np.all(np.isfinite(v)):
        logger.warning("v_desired contains NaN or inf (%s); commanding zero instead", v)
        v = np.zeros_like(v)
    x, violation, status, rows, advance = relax_kernel(np.ascontiguousarray(v), N, b, np.ascontiguousarray(soft),
                                                       np.ascontiguousarray(floors), RELAXATION_COMMAND_WEIGHT)
    if status == RELAX_DONE:
        return x, violation
    if status == RELAX_HARD_CONTRADICT:
        raise InfeasibleConstraintsError(f"the {rows} hard half-spaces contradict each other")
    if status == RELAX_STAGE_INFEASIBLE:
        raise InfeasibleConstraintsError(_infeasible_message(rows, advance))
    if status == RELAX_ILL_CONDITIONED:
        raise InfeasibleConstraintsError("the relaxation did not meet its hard rows (ill-conditioned rows)")
    raise InfeasibleConstraintsError("the relaxation's active set degenerated (dependent rows)")
