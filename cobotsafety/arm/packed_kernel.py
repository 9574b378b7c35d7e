"""One compiled 3D arm step on packed arrays: the arithmetic of ``cobotsafety.arm.step.step``.

Kinematics, the mapping, every measure row, the secondary-task scale, the half-spaces, the
projection, the integration and the safety net's re-check in one call; ``arm.step`` describes
the maths and is the spec. ``status``: 0 done; otherwise the reference must take this step: 1 a box zone
touched or penetrated.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.mapping_kernel import mapping_kernel
from cobotsafety.arm.packed_kinematics import attached_point, forward_kinematics, frame_jacobian, integrate, log3
from cobotsafety.arm.packed_measures import JOINT, capsule_points, constraint_distances, measure_rows
from cobotsafety.arm.packed_projection import RELAX_DONE, RELAX_OTHER, relax_kernel, slide_kernel
from cobotsafety.projection import RELAXATION_COMMAND_WEIGHT
from cobotsafety.arm.step import NEGLIGIBLE_NORMAL, SECONDARY_RELATIVE_TOLERANCE

CROSSING_TOLERANCE_M = 1e-9
BINDING_TOLERANCE = 1e-9
METHOD_ANTICIPATIVE, METHOD_STOP = 0, 1
STATUS_DONE, STATUS_BOX_TOUCHED, STATUS_CONTRADICTION = 0, 1, 2


@numba.njit(cache=True)
def tag_code(con: int, a: int, b: int) -> int:  # pragma: no cover - compiled
    """One integer per row tag ``(constraint, a, b)``, each -1 <= value < 2^16 - 1 (``tag_of`` inverts it)."""
    return ((con + 1) << 32) | ((a + 1) << 16) | (b + 1)


def tag_of(code: int) -> tuple[int, int, int]:
    """The ``(constraint, a, b)`` tag of ``tag_code``."""
    return (code >> 32) - 1, ((code >> 16) & 0xFFFF) - 1, (code & 0xFFFF) - 1


@numba.njit(cache=True)
def approach_limit(d: float, angular: bool, dt_s: float, max_accel: float) -> float:  # pragma: no cover - compiled
    """``step.approach_limit`` for one gap ``d`` [m or rad]."""
    d = max(d, 0.0)
    brake = np.inf if angular or not np.isfinite(max_accel) else np.sqrt(2.0 * max_accel * d)
    return -min(d / dt_s, brake)


@numba.njit(cache=True)
def kinematics(q, robot_int, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_R, ee_t,
               cap_joint, cap_p0l, cap_p1l):  # pragma: no cover - compiled
    """Joint placements, end-effector pose and Jacobian (6, nv), capsule points at ``q``."""
    nj, nv, ee_joint = jtype.shape[0], robot_int[0], robot_int[1]
    oR, op = np.empty((nj, 3, 3)), np.empty((nj, 3))
    forward_kinematics(q, jtype, axes, parent, idx_q, placement_R, placement_t, oR, op)
    p_ee = np.empty(3)
    attached_point(oR, op, ee_joint, ee_t, p_ee)
    R_ee = oR[ee_joint] @ ee_R
    J = np.empty((6, nv))
    frame_jacobian(p_ee, ee_joint, oR, op, axes, idx_v, support, J)
    c = cap_joint.shape[0]
    p0, p1, origins = np.empty((c, 3)), np.empty((c, 3)), np.empty((c, 3))
    capsule_points(oR, op, cap_joint, cap_p0l, cap_p1l, p0, p1, origins)
    return oR, op, p_ee, R_ee, J, p0, p1, origins


@numba.njit(cache=True)
def filter_kernel(vk, N, bnd, v_previous, with_previous: bool, dt_s: float, max_accel: float,
                  detail):  # pragma: no cover - compiled
    """``step.anticipative_command``: ``(command (k,), violation (m,), ok)``. The limitations hard,
    the acceleration bound soft; when the retreats contradict each other they give way too,
    down to approaching nothing; when that relaxation itself fails (degenerate rows): approach
    nothing, else stop, its ``relax_kernel`` status, rows and advance in ``detail[:3]`` and
    ``detail[3]`` = 1 for the stop. ``ok`` False: a case the kernel leaves to the reference."""
    k = vk.shape[0]
    n_hs = N.shape[0]
    n_acc = 2 * k if with_previous and np.isfinite(max_accel) else 0
    N_all = np.zeros((n_hs + n_acc, k))
    b_all = np.empty(n_hs + n_acc)
    N_all[:n_hs] = N
    b_all[:n_hs] = bnd
    soft = np.zeros(n_hs + n_acc, dtype=np.bool_)
    floors = np.full(n_hs + n_acc, -np.inf)
    if n_acc:
        change = max_accel * dt_s
        for a in range(k):
            N_all[n_hs + a, a] = 1.0
            N_all[n_hs + k + a, a] = -1.0
            b_all[n_hs + a] = v_previous[a] - change
            b_all[n_hs + k + a] = -v_previous[a] - change
            soft[n_hs + a] = True
            soft[n_hs + k + a] = True
    command, violation_all, status, _, _ = relax_kernel(vk, N_all, b_all, soft, floors, RELAXATION_COMMAND_WEIGHT)
    if status == RELAX_DONE:
        return command, np.zeros(n_hs), True
    # The limitations contradict each other: their retreats give way too.
    for i in range(n_hs):
        if bnd[i] > 0.0:
            soft[i] = True
            floors[i] = 0.0
    command, violation_all, status, rows, advance = relax_kernel(vk, N_all, b_all, soft, floors,
                                                                 RELAXATION_COMMAND_WEIGHT)
    if status == RELAX_DONE:
        return command, violation_all[:n_hs].copy(), True
    if status == RELAX_OTHER:
        return command, np.zeros(n_hs), False
    detail[0], detail[1], detail[2] = status, rows, advance
    violation = np.maximum(bnd, 0.0)
    command, status, _ = slide_kernel(vk, N, bnd - violation)
    if status != 0:
        command = np.zeros(k)
        detail[3] = 1.0
    return command, violation, True


@numba.njit(cache=True)
def unpack_robot(robot_i, robot_f):  # pragma: no cover - compiled
    """The robot's arrays as views of its two flat buffers (``packed.robot_buffers`` lays them
    out): ``(robot_int, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support,
    ee_R, ee_t, cap_joint, cap_p0l, cap_p1l, radius, lower, upper, limited, vlim)``. Two
    arguments instead of nineteen: numba's dispatcher types every argument at every call."""
    nj, nq, nv, c, L = robot_i[0], robot_i[1], robot_i[2], robot_i[4], robot_i[5]
    robot_int = robot_i[2:4]  # nv, the end-effector's joint
    o = 6
    jtype = robot_i[o:o + nj]
    parent = robot_i[o + nj:o + 2 * nj]
    idx_q = robot_i[o + 2 * nj:o + 3 * nj]
    idx_v = robot_i[o + 3 * nj:o + 4 * nj]
    o += 4 * nj
    support = robot_i[o:o + nj * nj].reshape((nj, nj))
    o += nj * nj
    cap_joint = robot_i[o:o + c]
    limited = robot_i[o + c:o + c + 2 * L].reshape((L, 2))
    axes = robot_f[0:3 * nj].reshape((nj, 3))
    o = 3 * nj
    placement_R = robot_f[o:o + 9 * nj].reshape((nj, 3, 3))
    o += 9 * nj
    placement_t = robot_f[o:o + 3 * nj].reshape((nj, 3))
    o += 3 * nj
    ee_R = robot_f[o:o + 9].reshape((3, 3))
    ee_t = robot_f[o + 9:o + 12]
    o += 12
    cap_p0l = robot_f[o:o + 3 * c].reshape((c, 3))
    cap_p1l = robot_f[o + 3 * c:o + 6 * c].reshape((c, 3))
    radius = robot_f[o + 6 * c:o + 7 * c]
    o += 7 * c
    lower = robot_f[o:o + nq]
    upper = robot_f[o + nq:o + 2 * nq]
    vlim = robot_f[o + 2 * nq:o + 2 * nq + nv]
    return (robot_int, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_R, ee_t, cap_joint,
            cap_p0l, cap_p1l, radius, lower, upper, limited, vlim)


@numba.njit(cache=True)
def unpack_human(human_f):  # pragma: no cover - compiled
    """``(p0 (h, 3), p1 (h, 3), radius (h,), v0 (h, 3), v1 (h, 3))`` as views of one flat buffer
    holding them in that order (13 floats a capsule)."""
    h = human_f.shape[0] // 13
    return (human_f[0:3 * h].reshape((h, 3)), human_f[3 * h:6 * h].reshape((h, 3)), human_f[6 * h:7 * h],
            human_f[7 * h:10 * h].reshape((h, 3)), human_f[10 * h:13 * h].reshape((h, 3)))


@numba.njit(cache=True)
def packed_step(q, vk, v_previous, with_previous: bool, dt_s: float, method: int, R_ref, with_orientation: bool,
                robot_i, robot_f, lever_m: float, kinds, reals, ints, before_start, n_before: int, max_rows: int,
                human_f, params):  # pragma: no cover - compiled
    """One step. ``robot_i``, ``robot_f``: the robot (``unpack_robot``); ``human_f``: the human
    capsules' end points, radii and end-point velocities, flat (``unpack_human``); ``params``:
    ArmParams as floats (see ``packed.params_vector``).

    Returns ``(status, q_next, qdot (nv,), command (k,), stopped, normals (m, k), bounds (m,), tags (m, 3),
    binding_codes (b,), relaxed_rows, worst_row, worst_violation, net_scale, p_ee, R_ee, J_ee (6, nv), p0, p1,
    origins, detail (4,))`` with the kinematics at ``q_next``: ``binding_codes`` the binding rows' tags as ``tag_code``,
    ``relaxed_rows`` how many rows' retreats were relaxed, the worst by ``worst_violation`` [m/s] at
    ``worst_row`` (-1: none); ``detail``: when the relaxation itself failed, its ``relax_kernel``
    status, rows and advance, and 1 if approaching nothing was impossible too (zeros otherwise).
    """
    (max_speed, width_m, width_rad, activation_m, w_threshold, damping_max, orientation_gain,
     centering_gain, velocity_limit_scale, buffer_m, buffer_rad, recovery_gain, max_accel) = (
        params[0], params[1], params[2], params[3], params[4], params[5], params[6], params[7], params[8],
        params[9], params[10], params[11], params[12])
    (robot_int, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_R, ee_t, cap_joint, cap_p0l,
     cap_p1l, radius, lower, upper, limited, vlim) = unpack_robot(robot_i, robot_f)
    hp0, hp1, hr, hv0, hv1 = unpack_human(human_f)
    nv = robot_int[0]
    k = vk.shape[0]
    detail = np.zeros(4)
    oR, op, p_ee, R_ee, J6, p0, p1, origins = kinematics(q, robot_int, jtype, axes, parent, idx_q, idx_v, placement_R,
                                                        placement_t, support, ee_R, ee_t, cap_joint, cap_p0l, cap_p1l)
    # ---- mapping (``step.mapping``) -----------------------------------------------------------
    J = np.ascontiguousarray(J6[:k])
    J_ang = np.ascontiguousarray(J6[3:])
    error = log3(R_ref @ R_ee.T) if with_orientation else np.zeros(3)
    centering = np.zeros(nv)
    if limited.shape[0] and centering_gain > 0:
        for i in range(limited.shape[0]):
            iq, iv = limited[i, 0], limited[i, 1]
            middle = 0.5 * (lower[iq] + upper[iq])
            span = upper[iq] - lower[iq]
            centering[iv] = -centering_gain * (q[iq] - middle) / max(span, 1e-6)
    M, c = mapping_kernel(J, J_ang, error, centering, damping_max, w_threshold, orientation_gain, 0.5 * vlim,
                          with_orientation)
    # ---- measures -----------------------------------------------------------------------------
    dist, A, rate = np.empty(max_rows), np.empty((max_rows, nv)), np.empty(max_rows)
    angular, tag = np.empty(max_rows, dtype=np.bool_), np.empty((max_rows, 3), dtype=np.int64)
    before = np.empty(n_before)
    m, ok = measure_rows(kinds, reals, ints, q, p_ee, J6, oR, op, p0, p1, radius, origins, cap_joint, axes, idx_v,
                         support, lower, upper, limited, hp0, hp1, hr, hv0, hv1, activation_m, dist, A, rate, angular,
                         tag, before, before_start)
    empty_f = np.zeros(0)
    if not ok:
        return (STATUS_BOX_TOUCHED, q, np.zeros(nv), empty_f, False, np.zeros((0, k)), empty_f,
                np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64), 0, -1, 0.0, 1.0, p_ee, R_ee, J6, p0, p1,
                origins, detail)
    dist, A, rate, angular, tag = dist[:m], A[:m], rate[:m], angular[:m], tag[:m]
    buffer = np.where(angular, buffer_rad, buffer_m)
    # ---- secondary-task scale (``step.secondary_scale``) ---------------------------------------
    if m > 0:
        ac = A @ c
        c_norm = np.sqrt(np.sum(c * c))
        scale = np.inf
        any_toward = False
        for i in range(m):
            a_norm = 0.0
            for j in range(nv):
                a_norm += A[i, j] * A[i, j]
            if ac[i] < -SECONDARY_RELATIVE_TOLERANCE * np.sqrt(a_norm) * c_norm:
                any_toward = True
                d = dist[i] - buffer[i]
                allowed = approach_limit(d, angular[i], dt_s, max_accel) if d > 0.0 else 0.0
                allowed = min(allowed - min(rate[i], 0.0), 0.0)
                scale = min(scale, allowed / ac[i])
        if any_toward:
            c = c * min(max(scale, 0.0), 1.0)
    # ---- half-spaces (``step.build_halfspaces``) ------------------------------------------------
    hard = method != METHOD_ANTICIPATIVE
    braking = np.inf if hard else max_accel
    normals = A @ M
    for i in range(m):
        s = 0.0
        for b in range(k):
            s += normals[i, b] * normals[i, b]
        if np.sqrt(s) < NEGLIGIBLE_NORMAL:
            normals[i, :] = 0.0
    secondary = A @ c
    human = np.minimum(rate, 0.0)
    offset = secondary + human
    rate_desired = normals @ vk + offset
    n_rows = m + 2 * nv + 2 * k
    all_normals = np.empty((n_rows, k))
    all_bounds = np.empty(n_rows)
    for i in range(m):
        width = (width_rad if angular[i] else width_m) * (not hard)
        d = dist[i] - buffer[i]
        bound = -recovery_gain * d if d <= 0.0 else approach_limit(d, angular[i], dt_s, braking)
        if width > 0 and d > 0 and d < width and rate_desired[i] < 0:
            bound = max(bound, d / width * rate_desired[i])
        all_bounds[i] = min(bound - human[i], max_speed) - secondary[i]
        all_normals[i] = normals[i]
    vmax = vlim * velocity_limit_scale
    for i in range(nv):
        all_normals[m + i] = M[i]
        all_normals[m + nv + i] = -M[i]
        all_bounds[m + i] = -vmax[i] - c[i]
        all_bounds[m + nv + i] = -vmax[i] + c[i]
    for a in range(k):
        for b in range(k):
            all_normals[m + 2 * nv + a, b] = 1.0 if a == b else 0.0
            all_normals[m + 2 * nv + k + a, b] = -1.0 if a == b else 0.0
        all_bounds[m + 2 * nv + a] = -max_speed
        all_bounds[m + 2 * nv + k + a] = -max_speed
    keep = np.ones(n_rows, dtype=np.bool_)
    for i in range(m):
        s = 0.0
        for b in range(k):
            s += all_normals[i, b] * all_normals[i, b]
        keep[i] = all_bounds[i] > -2.0 * max_speed * np.sqrt(s) - 1e-12
    N = all_normals[keep]
    bnd = all_bounds[keep]
    tags = np.full((n_rows, 3), -1, dtype=np.int64)
    tags[:m] = tag
    for i in range(2 * nv + 2 * k):
        tags[m + i, 0] = -1
        tags[m + i, 1] = i
    tags = tags[keep]
    # ---- projection (``step.filter_command``) --------------------------------------------------
    stopped = False
    violation = np.zeros(N.shape[0])
    if method == METHOD_ANTICIPATIVE:
        command, violation, ok = filter_kernel(vk, N, bnd, v_previous, with_previous, dt_s, max_accel, detail)
        if not ok:  # a zero normal in the relaxation's stage: the reference says why
            return (STATUS_CONTRADICTION, q, np.zeros(nv), command, False, N, bnd, tags, np.zeros(0, dtype=np.int64),
                    0, -1, 0.0, 1.0, p_ee, R_ee, J6, p0, p1, origins, detail)
        binding = N @ command - (bnd - violation) <= BINDING_TOLERANCE
        stopped = np.any(vk != 0.0) and np.all(np.abs(command) <= 1e-12)
        qdot = M @ command if stopped else M @ command + c
    else:  # stop
        binding = N @ vk < bnd - 1e-12
        stopped = np.any(binding)
        command = np.zeros(k) if stopped else vk.copy()
        qdot = np.zeros(nv) if stopped else M @ vk + c
    # ---- integrate and re-check (``step.integrate_with_safety_net``) ---------------------------
    travel = np.abs(qdot) * dt_s
    reach_linear = lever_m * travel.sum() + CROSSING_TOLERANCE_M
    reach_angular = (travel.max() if travel.shape[0] else 0.0) + CROSSING_TOLERANCE_M
    checked = np.zeros(kinds.shape[0], dtype=np.bool_)
    for con in range(kinds.shape[0]):
        part = before[before_start[con]:before_start[con + 1]]
        if part.shape[0]:
            checked[con] = part.min() <= (reach_angular if kinds[con] == JOINT else reach_linear)
    net_scale = 1.0
    low, high = 0.0, 1.0
    for attempt in range(27):
        # attempt 0: the full step; 1..25: bisection on its scale; 26: the scale found.
        if attempt == 0:
            scale = 1.0
        elif attempt == 26:
            scale = low
        else:
            scale = 0.5 * (low + high)
        q_next = q.copy()
        integrate(q, qdot * scale * dt_s, jtype, idx_q, idx_v, q_next)
        oR2, op2, p_ee2, R_ee2, J62, p02, p12, origins2 = kinematics(
            q_next, robot_int, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_R, ee_t,
            cap_joint, cap_p0l, cap_p1l)
        if attempt == 26:
            net_scale = low
            break
        admissible = True
        for con in range(kinds.shape[0]):
            if not checked[con]:
                continue
            part = before[before_start[con]:before_start[con + 1]]
            after, ok = constraint_distances(kinds[con], reals[con], ints[con], q_next, p_ee2, p02, p12, radius,
                                             lower, upper, limited, hp0, hp1, hr, 0.0)
            if not ok:
                return (STATUS_BOX_TOUCHED, q, qdot, command, stopped, N, bnd, tags, np.zeros(0, dtype=np.int64), 0, -1,
                        0.0, 1.0, p_ee, R_ee, J6, p0, p1, origins, detail)
            for i in range(part.shape[0]):
                if after[i] < min(part[i], 0.0) - CROSSING_TOLERANCE_M:
                    admissible = False
                    break
            if not admissible:
                break
        if attempt == 0:
            if admissible:
                break
        elif admissible:
            low = scale
        else:
            high = scale
    n_binding = 0
    for i in range(binding.shape[0]):
        n_binding += binding[i]
    codes = np.empty(n_binding, dtype=np.int64)
    n_binding = 0
    relaxed_rows, worst_row, worst_violation = 0, -1, 0.0
    for i in range(binding.shape[0]):
        if binding[i]:
            codes[n_binding] = tag_code(tags[i, 0], tags[i, 1], tags[i, 2])
            n_binding += 1
        if violation[i] > 0.0:
            relaxed_rows += 1
            if violation[i] > worst_violation:
                worst_row, worst_violation = i, violation[i]
    return (STATUS_DONE, q_next, qdot * net_scale, command * net_scale, stopped, N, bnd, tags, codes, relaxed_rows,
            worst_row, worst_violation, net_scale, p_ee2, R_ee2, J62, p02, p12, origins2, detail)
