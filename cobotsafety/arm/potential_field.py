"""Paper 2's potential field (Safeea & Neto 2019, eqs. 16-21, errata 5-6), compiled: the
repulsion at the arm's closest point to the human as a task, its joint velocity by damped least
squares (optionally with Chan and Dubey's joint-limit weights), and the whole field's command.

``step_kernel.arm_step`` calls these for the ``reactive`` strategy (the field itself) and for the
anticipative filter's evasion (``evasion_gain`` times the repulsion added to the command).
Distances in metres, speeds in m/s, joint velocities (nv,) in rad/s.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.kinematics import point_jacobian_row
from cobotsafety.arm.task import damped_least_squares


@numba.njit(cache=True)
def field_push(d_min, capsule, p_robot, p_human, nv, cap_joint, oR, op, axes, idx_v, support, critical_m,
               influence_m, k_rep_m_s, max_repulsion_m_s):  # pragma: no cover - compiled
    """Paper 2's repulsion (eqs. 18-21, errata 5-6) as a task: ``(J_cp (3, nv), f s (3,))``, with
    ``f = k_rep (d_o / (d - d_cr) - 1)`` (at most ``max_repulsion_m_s``) within ``d_cr + d_o`` of
    the human, ``s`` the unit vector from the human's closest point to the robot's, ``J_cp`` the
    Jacobian of the robot's closest point; a zero push outside (or without a human). The caller
    handles ``d <= d_cr``."""
    J_cp = np.zeros((3, nv))
    if capsule < 0 or not np.isfinite(d_min) or d_min >= influence_m + critical_m or d_min <= critical_m:
        return J_cp, np.zeros(3)
    f = min(k_rep_m_s * (influence_m / (d_min - critical_m) - 1.0), max_repulsion_m_s)
    if f <= 0.0:
        return J_cp, np.zeros(3)
    gap = p_robot - p_human
    s = gap / max(np.sqrt(np.sum(gap * gap)), 1e-9)
    e = np.zeros(3)
    for r in range(3):
        e[:] = 0.0
        e[r] = 1.0
        point_jacobian_row(e, p_robot, cap_joint[capsule], oR, op, axes, idx_v, support, J_cp[r])
    return J_cp, f * s


@numba.njit(cache=True)
def weighted_least_norm(J_cp, push, damping, joint_scale):  # pragma: no cover - compiled
    """The joint velocity (nv,) that gives ``push`` (3,) at the point of Jacobian ``J_cp``: the
    weighted least norm ``D DLS(J_cp D, push)``, ``D = diag(joint_scale)`` (all ones: paper 2's
    ``DLS(J_cp, push)``); zero for a zero push."""
    nv = J_cp.shape[1]
    if push[0] == 0.0 and push[1] == 0.0 and push[2] == 0.0:
        return np.zeros(nv)
    weighted = np.empty((3, nv))
    for r in range(3):
        for j in range(nv):
            weighted[r, j] = J_cp[r, j] * joint_scale[j]
    qdot = damped_least_squares(weighted, push, damping)
    for j in range(nv):
        qdot[j] *= joint_scale[j]
    return qdot


@numba.njit(cache=True)
def limit_scale(q, lower, upper, limited, nv):  # pragma: no cover - compiled
    """Chan and Dubey's weighted least norm ("A weighted least-norm solution based inverse
    kinematic scheme for redundant manipulators", IEEE T-RA 1995) as column scales (nv,):
    ``1 / sqrt(1 + |dH/dq_i|)``, ``H = sum (u - l)^2 / (4 (u - q)(q - l))`` the joint-limit
    measure (1 at mid-range, growing without bound at a limit; unlimited joints 1)."""
    scale = np.ones(nv)
    for i in range(limited.shape[0]):
        iq, iv = limited[i, 0], limited[i, 1]
        span = upper[iq] - lower[iq]
        to_upper, to_lower = max(upper[iq] - q[iq], 1e-6), max(q[iq] - lower[iq], 1e-6)
        grad = span * span * (2.0 * q[iq] - upper[iq] - lower[iq]) / (4.0 * to_upper * to_upper * to_lower * to_lower)
        scale[iv] = 1.0 / np.sqrt(1.0 + abs(grad))
    return scale


@numba.njit(cache=True)
def field_velocity(J, v_att, d_min, capsule, p_robot, p_human, cap_joint, oR, op, axes, idx_v, support,
                   critical_m, influence_m, k_rep_m_s, max_repulsion_m_s, damping):  # pragma: no cover - compiled
    """Paper 2's potential field (eqs. 16-21, errata 5-6): ``(qdot (nv,), stopped)``.

    ``qdot = DLS(J, v_att) + DLS(J_cp, f s)`` (``field_push``); at ``d <= d_cr`` the collision is unavoidable:
    stop."""
    nv = J.shape[1]
    if np.isfinite(d_min) and d_min <= critical_m:
        return np.zeros(nv), True
    J_cp, push = field_push(d_min, capsule, p_robot, p_human, nv, cap_joint, oR, op, axes, idx_v, support,
                            critical_m, influence_m, k_rep_m_s, max_repulsion_m_s)
    return damped_least_squares(J, v_att, damping) + weighted_least_norm(J_cp, push, damping, np.ones(nv)), False

