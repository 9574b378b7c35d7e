"""The joint filter's QP written plainly with quadprog (``arm/joint_filter.py``'s docstring), and
with the end-effector's speed balls written exactly, solved by scipy.

The command is ``qdot = q0 + B z`` and the filter minimises ``||z||^2`` subject to the rows
``N qdot >= b``, i.e. ``(N B) z >= b - N q0``. With soft rows (the lexicographic levels), the
soft rows first give way by least squares (``projection.relax``'s two stages, in ``z``).
"""

from __future__ import annotations

import numpy as np
import quadprog
import scipy.optimize

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


def ahead_cap_qp(q0: np.ndarray, B: np.ndarray, N: np.ndarray, b: np.ndarray, J: np.ndarray, speed_cap: float,
                 ee_prev: np.ndarray, lead: np.ndarray, ahead_cap: float, start: np.ndarray) -> np.ndarray:
    """``q0 + B z*`` with ``z* = argmin ||z||^2`` s.t. the rows ``N (q0 + B z) >= b`` (every row
    hard) and ``filter_rows``'s two balls written exactly, not by tangent planes::

        ||u|| <= speed_cap,   ||u + lead * (u - ee_prev)|| <= ahead_cap,   u = J (q0 + B z)

    (second-order cones, as squared norms: smooth and convex) by scipy's SLSQP from ``start``, a
    joint velocity inside both balls and the rows. ``ftol`` 1e-13: tighter, SLSQP runs into its
    iteration limit on some problems; it may end with status 8 ("positive directional derivative
    for linesearch") when it can gain no more: accepted, the test checks the answer."""
    JB, Jq0 = J @ B, J @ q0
    grow = 1.0 + lead
    G, h = N @ B, b - N @ q0

    def ahead(z):
        return grow * (Jq0 + JB @ z) - lead * ee_prev

    constraints = [
        {"type": "ineq", "fun": lambda z: G @ z - h, "jac": lambda z: G},
        {"type": "ineq", "fun": lambda z: speed_cap ** 2 - np.sum((Jq0 + JB @ z) ** 2),
         "jac": lambda z: -2.0 * (Jq0 + JB @ z) @ JB},
        {"type": "ineq", "fun": lambda z: ahead_cap ** 2 - np.sum(ahead(z) ** 2),
         "jac": lambda z: -2.0 * (ahead(z) * grow) @ JB},
    ]
    z0 = np.linalg.lstsq(B, start - q0, rcond=None)[0]
    found = scipy.optimize.minimize(lambda z: z @ z, z0, jac=lambda z: 2.0 * z, constraints=constraints,
                                    method="SLSQP", options={"ftol": 1e-13, "maxiter": 1000})
    if found.status not in (0, 8):
        raise ValueError(found.message)
    return q0 + B @ found.x
