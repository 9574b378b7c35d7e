"""The projection's oracles: quadprog's QP, paper 1's 2D rule, the two-stage relaxation."""

from __future__ import annotations

import numpy as np
import quadprog

from cobotsafety.least_distance import RELAXATION_COMMAND_WEIGHT


def quadprog_projection(v_desired: np.ndarray, normals: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Goldfarb-Idnani in Fortran: min 1/2 |v|^2 - v_d.v  s.t.  normals v >= bounds."""
    n = v_desired.shape[0]
    return quadprog.solve_qp(np.eye(n), v_desired, normals.T.copy(), bounds)[0]


def paper_rule_2d(v_desired: np.ndarray, unit_normals: np.ndarray) -> np.ndarray:
    """Paper 1, section III.A, written from the text: slide on each active limitation with
    eq. (1), keep the result that satisfies every limitation, else zero."""
    candidates = []
    for n in unit_normals:
        along = v_desired @ n
        candidates.append(v_desired.copy() if along >= 0 else v_desired - along * n)
    for candidate in candidates:
        if np.all(unit_normals @ candidate >= -1e-12):
            return candidate
    return np.zeros(2)


def quadprog_relaxation(v_desired, normals, bounds, soft, floor, slack=1e-12):
    """``projection.relax``'s two stages written as QPs with slack variables, solved by quadprog.

    Stage 1: min w^2 |v|^2 + |s|^2 over (v, s) s.t. hard rows, soft rows + s, floors.
    Stage 2: min |v - v_desired|^2 s.t. the soft bounds lowered by the stage-1 slacks.
    ``slack`` loosens the bounds a hair (quadprog refuses some degenerate active sets)."""
    n, k = normals.shape[1], int(soft.sum())
    H = np.diag(np.concatenate([np.full(n, RELAXATION_COMMAND_WEIGHT ** 2), np.ones(k)]))
    C = np.zeros((normals.shape[0], n + k))
    C[:, :n] = normals
    C[np.flatnonzero(soft), n + np.arange(k)] = 1.0
    floored = np.flatnonzero(soft & np.isfinite(floor))
    C = np.vstack([C, np.hstack([normals[floored], np.zeros((floored.size, k))])])
    b = np.concatenate([bounds, floor[floored] - slack])
    x = quadprog.solve_qp(H, np.zeros(n + k), C.T.copy(), b)[0]
    violation = np.zeros_like(bounds)
    violation[soft] = np.maximum(bounds[soft] - normals[soft] @ x[:n], 0.0)
    relaxed = bounds - violation
    v = quadprog.solve_qp(np.eye(n), v_desired, normals.T.copy(), relaxed - slack)[0]
    return v, violation


def kkt_residual(v, v_desired, normals, bounds, active_tol=1e-9) -> float:
    """How far ``v`` is from the projection's optimality conditions: the largest row violation
    and the residual of ``v - v_desired = normals_active^T lambda, lambda >= 0`` (bounded
    least squares over the rows within ``active_tol`` of their bound)."""
    from scipy.optimize import lsq_linear

    slack = normals @ v - bounds
    active = slack <= active_tol
    violation = max(0.0, float(-slack.min(initial=0.0)))
    if not active.any():
        return max(violation, float(np.max(np.abs(v - v_desired))))
    fit = lsq_linear(normals[active].T, v - v_desired, bounds=(0.0, np.inf), method="bvls", tol=1e-14)
    return max(violation, float(np.max(np.abs(normals[active].T @ fit.x - (v - v_desired)))))
