"""The joint filter's QP written plainly with quadprog (``arm/joint_filter.py``'s docstring).

The command is ``qdot = q0 + B z`` and the filter minimises ``||z||^2`` subject to the rows
``N qdot >= b``, i.e. ``(N B) z >= b - N q0``. With soft rows (the lexicographic levels), the
soft rows first give way by least squares (``projection.relax``'s two stages, in ``z``).
"""

from __future__ import annotations

import numpy as np
import quadprog

from cobotsafety.least_distance import RELAXATION_COMMAND_WEIGHT

from .projection import quadprog_relaxation


def filter_qp(q0: np.ndarray, B: np.ndarray, N: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``q0 + B z*`` with ``z* = argmin ||z||^2 s.t. N (q0 + B z) >= b`` (every row hard)."""
    G = N @ B
    h = b - N @ q0
    z = quadprog.solve_qp(np.eye(B.shape[1]), np.zeros(B.shape[1]), G.T.copy(), h)[0]
    return q0 + B @ z


def lexicographic_qp(q0: np.ndarray, B: np.ndarray, N: np.ndarray, b: np.ndarray, soft: np.ndarray,
                     floors: np.ndarray | None = None):
    """``(qdot, violation)``: the soft rows relaxed by least squares while the others stay hard
    (stage 1; a soft row with a finite ``floors`` entry at most down to ``N qdot >= floor``),
    then the closest command to ``q0`` on the relaxed rows (stage 2)."""
    G = N @ B
    h = b - N @ q0
    floor = np.full(len(b), -np.inf) if floors is None else floors - N @ q0
    z, violation = quadprog_relaxation(np.zeros(B.shape[1]), G, h, soft, floor, slack=0.0)
    return q0 + B @ z, violation


def stage1_objective(q0: np.ndarray, B: np.ndarray, N: np.ndarray, b: np.ndarray, violation: np.ndarray,
                     slack: float = 1e-9) -> float:
    """Stage 1's objective at the relaxation ``violation``: ``w^2 ||z||^2 + ||violation||^2``
    with ``z`` the least command meeting the relaxed rows (``N (q0 + B z) >= b - violation -
    slack``; ``slack`` a hair for the rounding of a solver's own active rows)."""
    qdot = filter_qp(q0, B, N, b - violation - slack)
    z = np.linalg.lstsq(B, qdot - q0, rcond=None)[0]
    return float(RELAXATION_COMMAND_WEIGHT ** 2 * z @ z + violation @ violation)
