"""Paper 2's collision avoidance controller (section 4, eqs. 14-21 with errata 5-6).

Attraction: ``e = p_target - p_ee`` (eq. 14, erratum 5), ``v_att = PI(e)`` (eq. 15, anti-windup),
``qdot_att = DLS(J, v_att)`` (eq. 16). Repulsion at the robot point closest to the human:
``s = unit(p_r - p_o)`` (17), ``f = k_rep (d_o / (d_min - d_cr) - 1)`` when
``d_min < d_o + d_cr`` (18), ``v_rep = f s`` (19), ``qdot_rep = DLS(J_cp, v_rep)`` (20,
erratum 6: ``J_cp^T``). Sum (21). When ``d_min <= d_cr`` the collision is unavoidable: stop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.control.dls import damped_least_squares
from cobotsafety.control.human_constraint import DEFAULT_ACTIVATION_M, DEFAULT_CRITICAL_M


@dataclass(frozen=True)
class PotentialFieldParams:
    critical_m: float = DEFAULT_CRITICAL_M
    """d_cr [m]."""
    influence_m: float = DEFAULT_ACTIVATION_M - DEFAULT_CRITICAL_M
    """d_o [m]: repulsion starts at d_o + d_cr."""
    k_rep_m_s: float = 0.08
    """k_rep [m/s]."""
    max_repulsion_m_s: float = 1.0
    damping: float = 1e-3
    """lambda of eqs. 16 and 20."""


def repulsion_speed(d_min: float, params: PotentialFieldParams) -> float:
    """Eq. 18: the repulsion's magnitude [m/s] at minimum distance ``d_min``."""
    if d_min >= params.influence_m + params.critical_m:
        return 0.0
    if d_min <= params.critical_m:
        return params.max_repulsion_m_s
    return min(params.k_rep_m_s * (params.influence_m / (d_min - params.critical_m) - 1.0), params.max_repulsion_m_s)


def potential_field_qdot(J_ee: np.ndarray, v_att: np.ndarray, d_min: float, p_robot: np.ndarray,
                         p_human: np.ndarray, J_cp: np.ndarray | None, params: PotentialFieldParams) -> tuple[np.ndarray, bool]:
    """Eqs. 16-21: ``(qdot, stopped)``; stopped when the collision is unavoidable (d_min <= d_cr)."""
    if np.isfinite(d_min) and d_min <= params.critical_m:
        return np.zeros(J_ee.shape[1]), True
    qdot = damped_least_squares(J_ee, v_att, params.damping)
    f_rep = repulsion_speed(d_min, params) if np.isfinite(d_min) else 0.0
    if f_rep > 0.0 and J_cp is not None:
        gap = p_robot - p_human
        s = gap / max(np.linalg.norm(gap), 1e-9)
        qdot = qdot + damped_least_squares(J_cp, f_rep * s, params.damping)
    return qdot, False
