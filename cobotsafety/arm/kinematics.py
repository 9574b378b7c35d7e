"""Compiled kinematics of a serial arm from pinocchio's joint placements.

Equal to pinocchio (to rounding) for the joint types the supported robots use: revolute about a
joint axis (``JointModelRX``/``RY``/``RZ``, angle ``q``) and the continuous revolute about z
(``JointModelRUBZ``, ``q = (cos, sin)``, nq = 2, nv = 1). ``oMi[j] = oMi[parent] *
placement[j] * M_joint(q)``; the world Jacobian column of joint ``i`` at a point ``p`` is
``a_i x (p - o_i)`` (translation) and ``a_i`` (rotation), ``a_i`` the joint's axis in the world.
``integrate`` is ``pin.integrate``; ``log3`` is pinocchio's ``log3`` (same branches).
Tests compare each against pinocchio (``tests/test_arm_kinematics.py``).

``frame_jacobian``, ``drift_along`` and ``_world_axis`` are inlined where they are called
(``inline="always"``): a compiled call that takes arrays costs two atomic reference counts per
array, and inside the rows' per-pair helpers (``limitations/point_row.py``) a call also keeps
numba from pruning the counts of every array the helper takes; inlined, the human-aware panda
step makes ~1,340 of them instead of ~1,960 (``docs/step_profile.md``, 2026-12-07).
"""

from __future__ import annotations

import numba
import numpy as np

JOINT_REVOLUTE, JOINT_RUBZ = 0, 3
JOINT_CODES = {"JointModelRX": JOINT_REVOLUTE, "JointModelRY": JOINT_REVOLUTE, "JointModelRZ": JOINT_REVOLUTE,
               "JointModelRevoluteUnaligned": JOINT_REVOLUTE, "JointModelRUBZ": JOINT_RUBZ}
JOINT_AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0),
              "JointModelRUBZ": (0.0, 0.0, 1.0)}


def joint_axis_local(joint) -> tuple[float, float, float]:
    """The unit axis of a pinocchio revolute joint model in its own frame."""
    name = joint.shortname()
    return JOINT_AXES[name] if name in JOINT_AXES else tuple(float(a) for a in joint.extract().axis)

_EPS = float(np.finfo(float).eps)
_LOG3_PRECISION = _EPS ** (1.0 / 3.0)  # pinocchio's TaylorSeriesExpansion<double>::precision<2>()


@numba.njit(cache=True)
def forward_kinematics(q, jtype, axes, parent, idx_q, placement_R, placement_t, oR, op):  # pragma: no cover - compiled
    """World placements of every joint: rotations ``oR`` (nj, 3, 3), origins ``op`` (nj, 3), in place."""
    nj = jtype.shape[0]
    Rj = np.empty((3, 3))
    liR = np.empty((3, 3))
    for r in range(3):
        op[0, r] = 0.0
        for col in range(3):
            oR[0, r, col] = 1.0 if r == col else 0.0
    for j in range(1, nj):
        t = jtype[j]
        iq = idx_q[j]
        if t == JOINT_RUBZ:
            c, s = q[iq], q[iq + 1]
        else:
            s, c = np.sin(q[iq]), np.cos(q[iq])
        # Local rotation of the joint about its unit axis (Rodrigues; exact for x, y, z).
        x, y, z = axes[j, 0], axes[j, 1], axes[j, 2]
        c1 = 1.0 - c
        Rj[0, 0], Rj[1, 1], Rj[2, 2] = c1 * x * x + c, c1 * y * y + c, c1 * z * z + c
        Rj[0, 1], Rj[1, 0] = c1 * x * y - s * z, c1 * x * y + s * z
        Rj[0, 2], Rj[2, 0] = c1 * x * z + s * y, c1 * x * z - s * y
        Rj[1, 2], Rj[2, 1] = c1 * y * z - s * x, c1 * y * z + s * x
        pj = parent[j]
        # liMi = placement * M_joint: rotation placement_R @ Rj, translation placement_t.
        for r in range(3):
            for col in range(3):
                liR[r, col] = placement_R[j, r, 0] * Rj[0, col] + placement_R[j, r, 1] * Rj[1, col] \
                    + placement_R[j, r, 2] * Rj[2, col]
        for r in range(3):
            op[j, r] = op[pj, r] + oR[pj, r, 0] * placement_t[j, 0] + oR[pj, r, 1] * placement_t[j, 1] \
                + oR[pj, r, 2] * placement_t[j, 2]
            for col in range(3):
                oR[j, r, col] = oR[pj, r, 0] * liR[0, col] + oR[pj, r, 1] * liR[1, col] + oR[pj, r, 2] * liR[2, col]


@numba.njit(cache=True)
def attached_point(oR, op, joint: int, p_local, out):  # pragma: no cover - compiled
    """World position (3,) of a point ``p_local`` fixed in ``joint``'s frame, into ``out``."""
    for r in range(3):
        out[r] = op[joint, r] + oR[joint, r, 0] * p_local[0] + oR[joint, r, 1] * p_local[1] + oR[joint, r, 2] * p_local[2]


@numba.njit(cache=True, inline="always")
def _world_axis(oR, axes, i: int):  # pragma: no cover - compiled
    x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
    return (oR[i, 0, 0] * x + oR[i, 0, 1] * y + oR[i, 0, 2] * z, oR[i, 1, 0] * x + oR[i, 1, 1] * y + oR[i, 1, 2] * z,
            oR[i, 2, 0] * x + oR[i, 2, 1] * y + oR[i, 2, 2] * z)


@numba.njit(cache=True)
def point_jacobian_row(u, p, joint: int, oR, op, axes, idx_v, support, out):  # pragma: no cover - compiled
    """``out`` (nv,) = ``u @ J_p``: the rate of ``u . p`` for the point ``p`` fixed to ``joint``."""
    for i in range(out.shape[0]):
        out[i] = 0.0
    for i in range(1, axes.shape[0]):
        if not support[joint, i]:
            continue
        ax, ay, az = _world_axis(oR, axes, i)
        rx, ry, rz = p[0] - op[i, 0], p[1] - op[i, 1], p[2] - op[i, 2]
        out[idx_v[i]] = u[0] * (ay * rz - az * ry) + u[1] * (az * rx - ax * rz) + u[2] * (ax * ry - ay * rx)


@numba.njit(cache=True, inline="always")
def frame_jacobian(p, joint: int, oR, op, axes, idx_v, support, J):  # pragma: no cover - compiled
    """``J`` (6, nv): LOCAL_WORLD_ALIGNED Jacobian of a frame at ``p`` fixed to ``joint``."""
    J[:, :] = 0.0
    for i in range(1, axes.shape[0]):
        if not support[joint, i]:
            continue
        ax, ay, az = _world_axis(oR, axes, i)
        rx, ry, rz = p[0] - op[i, 0], p[1] - op[i, 1], p[2] - op[i, 2]
        v = idx_v[i]
        J[0, v] = ay * rz - az * ry
        J[1, v] = az * rx - ax * rz
        J[2, v] = ax * ry - ay * rx
        J[3, v] = ax
        J[4, v] = ay
        J[5, v] = az


@numba.njit(cache=True)
def fastest_capsule_end(oR, op, axes, parent, idx_v, cap_joint, p0, p1, qdot):  # pragma: no cover - compiled
    """The fastest speed [m/s] of the capsules' axis end points (``p0``, ``p1``, each fixed to
    ``cap_joint``) at ``qdot``: every joint frame's angular velocity ``w_j = w_parent + a_j
    qdot_j`` and its origin's velocity ``v_j = v_parent + w_parent x (o_j - o_parent)``, then
    ``v_p = v_j + w_j x (p - o_j)`` (the speed ``J_p qdot`` of ``frame_jacobian``, in one pass)."""
    nj = axes.shape[0]
    w, v = np.zeros((nj, 3)), np.zeros((nj, 3))
    for j in range(1, nj):
        pj = parent[j]
        ax, ay, az = _world_axis(oR, axes, j)
        s = qdot[idx_v[j]]
        rx, ry, rz = op[j, 0] - op[pj, 0], op[j, 1] - op[pj, 1], op[j, 2] - op[pj, 2]
        v[j, 0] = v[pj, 0] + w[pj, 1] * rz - w[pj, 2] * ry
        v[j, 1] = v[pj, 1] + w[pj, 2] * rx - w[pj, 0] * rz
        v[j, 2] = v[pj, 2] + w[pj, 0] * ry - w[pj, 1] * rx
        w[j, 0], w[j, 1], w[j, 2] = w[pj, 0] + ax * s, w[pj, 1] + ay * s, w[pj, 2] + az * s
    fastest = 0.0
    for c in range(cap_joint.shape[0]):
        j = cap_joint[c]
        for end in range(2):
            p = p0[c] if end == 0 else p1[c]
            rx, ry, rz = p[0] - op[j, 0], p[1] - op[j, 1], p[2] - op[j, 2]
            vx = v[j, 0] + w[j, 1] * rz - w[j, 2] * ry
            vy = v[j, 1] + w[j, 2] * rx - w[j, 0] * rz
            vz = v[j, 2] + w[j, 0] * ry - w[j, 1] * rx
            fastest = max(fastest, np.sqrt(vx * vx + vy * vy + vz * vz))
    return fastest


@numba.njit(cache=True, inline="always")
def drift_along(u, J, qdot):  # pragma: no cover - compiled
    """``u . (dJ/dt qdot)`` [m/s^2]: how fast the point of the frame Jacobian ``J`` (6, nv;
    ``frame_jacobian``'s, columns in the chain's order, a parent before its child) accelerates
    along ``u`` when the arm moves at ``qdot`` with no joint acceleration (the centripetal and
    Coriolis part of its acceleration). Column ``i``'s translation ``j_i = z_i x (p - o_i)``
    changes at ``(w_i x z_i) x (p - o_i) + z_i x (v_p - v_{o_i})`` (``w_i`` the angular velocity
    of the joints before ``i``), which by Jacobi's identity sums to::

        dJ/dt qdot = sum_i qdot_i (w_i x j_i + z_i x sum_{k >= i} qdot_k j_k)

    (``tests/test_arm_kinematics.py`` compares it with pinocchio's classical acceleration)."""
    wx, wy, wz = 0.0, 0.0, 0.0
    tx, ty, tz = 0.0, 0.0, 0.0
    for k in range(J.shape[1]):
        tx += J[0, k] * qdot[k]
        ty += J[1, k] * qdot[k]
        tz += J[2, k] * qdot[k]
    ax, ay, az = 0.0, 0.0, 0.0
    for i in range(J.shape[1]):
        s = qdot[i]
        if s == 0.0:
            continue
        jx, jy, jz = J[0, i], J[1, i], J[2, i]
        zx, zy, zz = J[3, i], J[4, i], J[5, i]
        ax += s * ((wy * jz - wz * jy) + (zy * tz - zz * ty))
        ay += s * ((wz * jx - wx * jz) + (zz * tx - zx * tz))
        az += s * ((wx * jy - wy * jx) + (zx * ty - zy * tx))
        tx, ty, tz = tx - s * jx, ty - s * jy, tz - s * jz
        wx, wy, wz = wx + s * zx, wy + s * zy, wz + s * zz
    return u[0] * ax + u[1] * ay + u[2] * az


@numba.njit(cache=True)
def integrate(q, v, jtype, idx_q, idx_v, out):  # pragma: no cover - compiled
    """``pin.integrate(model, q, v)`` into ``out`` (RUBZ: rotate (cos, sin), first-order renormalise)."""
    for j in range(1, jtype.shape[0]):
        iq, iv = idx_q[j], idx_v[j]
        if jtype[j] == JOINT_RUBZ:
            ca, sa = q[iq], q[iq + 1]
            so, co = np.sin(v[iv]), np.cos(v[iv])
            c1 = co * ca - so * sa
            s1 = so * ca + co * sa
            norm2 = c1 * c1 + s1 * s1
            f = (3.0 - norm2) / 2.0
            out[iq], out[iq + 1] = c1 * f, s1 * f
        else:
            out[iq] = q[iq] + v[iv]


@numba.njit(cache=True)
def _theta_axis(i0: int, val: float, R):  # pragma: no cover - compiled
    i1, i2 = (i0 + 1) % 3, (i0 + 2) % 3
    s = np.sqrt(val + _EPS + _EPS * _EPS) * (1.0 if R[i2, i1] >= R[i1, i2] else -1.0)
    axis = np.zeros(3)
    axis[i0] = s / 2.0
    axis[i1] = 1.0 / (2.0 * s) * (R[i1, i0] + R[i0, i1])
    axis[i2] = 1.0 / (2.0 * s) * (R[i2, i0] + R[i0, i2])
    w = 1.0 / (2.0 * s) * (R[i2, i1] - R[i1, i2])
    norm = np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    return 2.0 * np.arctan2(norm, w), axis / norm


@numba.njit(cache=True)
def log3(R_in):  # pragma: no cover - compiled
    """pinocchio's ``log3`` (renormalised rotation, Taylor branch near 0, axis branch near pi)."""
    R = np.empty((3, 3))
    n0 = np.sqrt(R_in[0, 0] ** 2 + R_in[1, 0] ** 2 + R_in[2, 0] ** 2)
    n1 = np.sqrt(R_in[0, 1] ** 2 + R_in[1, 1] ** 2 + R_in[2, 1] ** 2)
    for r in range(3):
        R[r, 0] = R_in[r, 0] / n0
        R[r, 1] = R_in[r, 1] / n1
    R[0, 2] = R[1, 0] * R[2, 1] - R[2, 0] * R[1, 1]
    R[1, 2] = R[2, 0] * R[0, 1] - R[0, 0] * R[2, 1]
    R[2, 2] = R[0, 0] * R[1, 1] - R[1, 0] * R[0, 1]
    R[0, 0] = R[1, 1] * R[2, 2] - R[2, 1] * R[1, 2]
    R[1, 0] = R[2, 1] * R[0, 2] - R[0, 1] * R[2, 2]
    R[2, 0] = R[0, 1] * R[1, 2] - R[1, 1] * R[0, 2]
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    cos_value = (tr - 1.0) / 2.0
    prec = _LOG3_PRECISION
    res = np.empty(3)
    if cos_value >= -1.0 + prec:
        acos_expansion = np.sqrt(2.0 * (1.0 - cos_value) + _EPS * _EPS)
        if tr <= 3.0 - prec:
            theta = np.arccos(cos_value) if tr >= -1.0 + prec else np.pi - acos_expansion
        else:
            theta = acos_expansion
        a0, a1, a2 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
        # pinocchio's unSkew: 0.5 * (R - R^T) entries.
        a0, a1, a2 = 0.5 * a0, 0.5 * a1, 0.5 * a2
        n2 = a0 * a0 + a1 * a1 + a2 * a2
        t = theta / np.sin(theta) if theta >= prec else 1.0 + n2 / 6.0 + n2 * n2 * 3.0 / 40.0
        res[0], res[1], res[2] = t * a0, t * a1, t * a2
        return res
    v0 = 2.0 * R[0, 0] - tr + 1.0
    v1 = 2.0 * R[1, 1] - tr + 1.0
    v2 = 2.0 * R[2, 2] - tr + 1.0
    if v0 >= v1:
        theta, axis = _theta_axis(0, v0, R) if v0 >= v2 else _theta_axis(2, v2, R)
    else:
        theta, axis = _theta_axis(1, v1, R) if v1 >= v2 else _theta_axis(2, v2, R)
    return theta * axis
