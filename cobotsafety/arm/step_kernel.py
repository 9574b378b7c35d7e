"""One control step of a 3D arm, compiled: kinematics, limitations, filter, integration, check.

``arm_step`` is the only implementation of the step (``controller.ArmController`` calls it once
per period; with ``NUMBA_DISABLE_JIT=1`` this source runs as written). Its arguments are flat
buffers grouped by role:

* ``state_f``: ``q`` (nq), the previous step's joint velocity (nv) and acceleration (nv), the
  end-effector's previous velocity (3) and acceleration (3), as executed (its path's backward
  differences). Updated in place.
* ``kin_f``: the previous step's ``out_f``: its kinematics at its q_next are this step's at
  ``q`` when ``q`` is that q_next (checked bit for bit; else, e.g. an empty array, computed).
* the command: the desired end-effector velocity ``v`` (3) [m/s] (with ``FLAG_JOINT_COMMAND``:
  a desired joint velocity (nv) [rad/s], a posture move followed in joint space), the period
  ``dt_s`` [s], the strategy (``STRATEGIES``), ``flags`` (``FLAG_*``: orientation hold, SSM's
  speed scaling, forced stop, SSM's protective stop, that stop under way in the previous step,
  a joint command), how far
  ahead of its frame the human is extrapolated [s], and ``reference_f``: the reference
  orientation (9, row-major) and the speed cap [m/s].
* ``robot_i``, ``robot_f``: the robot (``robot_model.robot_buffers``).
* ``scene_i`` (n, 2): each limitation's kind and skipped capsules; ``scene_f`` (n, 12): its
  numbers (``limitations.registry.pack_scene``).
* ``human_f``: the human capsules and their velocities (``limitations.human.human_buffer``).
* ``settings_f``: ``FilterSettings.vector()``.
* ``out_f``, ``out_i``: what the step did (``output_layout`` says where).

The step:

1. kinematics at ``q`` (``kinematics.py``, or the previous step's at its q_next), the task's
   joint velocity ``q0 = M v + c`` and the null basis (``task.py``); a joint command is ``q0``
   itself, followed by least squares in joint space (as the field's and ``off``'s);
2. every limitation's rows ``(d, a, rate)`` (``limitations/``) and their bounds
   (``limitation_bounds``): the approach speed from which the arm can still brake before the
   limitation (``braking.braking_speed``); for a person walking at the arm, ISO/TS 15066's
   separation (the arm must be able to stand still before they reach it, their rows watched
   from as far as they walk while the whole arm stops), the plan retreating as fast as they
   come; SSM's speed limit; the joints' speed limits; the motion box of each joint
   (acceleration and jerk limits from the previous step) and of the end-effector;
3. the strategy: ``anticipative`` filters ``q0`` (``joint_filter``), next to a person ``q0``
   plus ``evasion_gain`` times paper 2's repulsion (``field_push``, ``weighted_least_norm``);
   ``stop`` commands zero as soon as ``q0`` would break a bound (the arm brakes within its
   limits); ``reactive`` is paper 2's potential field at the human's closest point, projected
   onto the other limitations (it slides off them as the anticipative filter does); ``off``
   keeps only the robot's own speed, acceleration and jerk limits;
4. integration (``pin.integrate``'s arithmetic) and the safety net (``safety_net``): a step
   that would cross a limitation clear before it (the rows are first-order on curved
   limitations), or deepen one already violated, is scaled down by bisection; only limitations
   the step can reach are re-checked (every distance is 1-Lipschitz in the arm's points, which
   move at most ``lever * sum |dq|``);
5. the new kinematics and the human's minimum distance with its witness points.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.braking import arm_stop_time, stop_distance
from cobotsafety.arm.joint_filter import (BINDING_TOLERANCE, LEVEL_APPROACH_NOTHING, LEVEL_EXACT, LEVEL_RELAXED,
                                          HAND, LEVEL_SMOOTHNESS, LEVEL_STOPPED, LIMITATION, MOTION, PLAN, RECOVERY,
                                          SPEED_CUTS, VELOCITY, filter_rows, is_motion)
from cobotsafety.arm.kinematics import fastest_capsule_end, forward_kinematics, frame_jacobian, integrate, log3
from cobotsafety.arm.limitation_bounds import limitation_bounds
from cobotsafety.arm.limitations import human as human_kind
from cobotsafety.arm.limitations import joint_range
from cobotsafety.arm.limitations.rows import kind_count, kind_distances, kind_rows
from cobotsafety.arm.motion_box import (EE_AXIS_SHARE, EE_MOTION_SHARE, MOTION_MARGIN, ROUNDING_RAD_S, motion_box,
                                        ramp_acceleration, within_hand_ball)
from cobotsafety.arm.motion_limits import OVER_LIMIT_RATIO
from cobotsafety.arm.potential_field import field_push, field_velocity, limit_scale, weighted_least_norm
from cobotsafety.arm.ssm import approach_speed_kernel, separation_kernel
from cobotsafety.arm.task import null_basis, task_mapping
from cobotsafety.small_linalg import matmul, matmul_nt, matvec

ANTICIPATIVE, STOP, REACTIVE, OFF = 0, 1, 2, 3
STRATEGIES = ("anticipative", "stop", "reactive", "off")
#: ``flags`` bits: hold the reference orientation; ISO/TS 15066 SSM's speed scaling; brake to a
#: stop; SSM's protective stop; that stop under way in the previous step; the command is a joint
#: velocity.
FLAG_ORIENTATION, FLAG_SSM, FLAG_STOP, FLAG_PROTECTIVE, FLAG_PROTECTIVE_HELD, FLAG_JOINT_COMMAND = 1, 2, 4, 8, 16, 32
#: ``out_i`` header: status, filter level, stopped, binding rows, relaxed rows, worst relaxed
#: row, motion limited, smoothness given up, protective stop, motion-limited rows, evading (the
#: anticipative command carried the repulsion from a person), the hand's executed path over its
#: limits (below); then the binding rows' codes, then the motion-limited rows' codes.
(I_STATUS, I_LEVEL, I_STOPPED, I_BINDING, I_RELAXED, I_WORST, I_MOTION_LIMITED, I_SMOOTHNESS, I_PROTECTIVE,
 I_MOTION_COUNT, I_EVADING, I_HAND_OVER) = range(12)
OUT_I_HEADER = 16
#: ``out_i[I_SMOOTHNESS]``, smoothness given up for safety (0: not): the joints' motion limits
#: gave way (the hand's may too); only the hand's (the joints' kept); the safety net scaled the
#: step (the filter's command kept every row).
GAVE_WAY_JOINTS, GAVE_WAY_HAND, GAVE_WAY_NET = 1, 2, 3
#: ``out_i[I_HAND_OVER]`` 1: the end-effector's executed path (the backward differences of its
#: positions, as ``motion_ratios`` measures a run) went over the robot's end-effector
#: acceleration or jerk limit this step (by more than ``OVER_LIMIT_RATIO``; which one: the two
#: ratios in ``out_f``). The filter bounds the hand's acceleration on ``J qddot``; the path's
#: curvature ``dJ/dt qdot`` has the tenth of the limit left for it, which a body turning fast in
#: the hand's null space can exceed.
STATUS_DONE, STATUS_UNKNOWN_KIND = 0, 1
#: Row codes: ``(owner + 4) << 20 | a << 10 | b``; owner >= 0 a limitation (its index), else
#: one of these (``a`` a joint or axis, ``b`` 0 lower / 1 upper).
OWNER_VELOCITY, OWNER_MOTION, OWNER_SPEED, OWNER_EE_MOTION = -1, -2, -3, -4
CROSSING_TOLERANCE_M = 1e-9


@numba.njit(cache=True)
def row_code(owner, a, b):  # pragma: no cover - compiled
    return ((owner + 4) << 20) | (a << 10) | b


def decode_row(code: int) -> tuple[int, int, int]:
    """``(owner, a, b)`` of a row code."""
    return (code >> 20) - 4, (code >> 10) & 1023, code & 1023


@numba.njit(cache=True)
def output_layout(nq, nv, n_caps, nj):  # pragma: no cover - compiled
    """Offsets in ``out_f``: q_next, qdot, p_ee, R_ee, J6, cap_p0, cap_p1, v_commanded,
    v_executed, min_distance, p_robot, p_human, net_scale, worst_violation, motion_violation,
    brake_factor (the largest factor by which a bound exceeded the motion limits), the step's
    joint acceleration ratio (max over joints of |qddot| / limit), the joints' rotations oR
    (nj, 3, 3) and positions op (nj, 3) at q_next, the executed hand path's acceleration and jerk
    over the robot's end-effector limits (norms; ``I_HAND_OVER``), and the total size. The
    kinematics at q_next (p_ee to cap_p1, oR, op) are the next step's at its q
    (``previous_kinematics``)."""
    sizes = (nq, nv, 3, 9, 6 * nv, 3 * n_caps, 3 * n_caps, 3, 3, 1, 3, 3, 1, 1, 1, 1, 1, 9 * nj, 3 * nj, 2)
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    for i in range(len(sizes)):
        offsets[i + 1] = offsets[i] + sizes[i]
    return offsets


@numba.njit(cache=True, inline="always")
def unpack_robot(robot_i, robot_f):  # pragma: no cover - compiled
    """The robot's arrays as views of its buffers (``robot_model.robot_buffers``)."""
    nj, nq, nv, ee_joint, c, L = robot_i[0], robot_i[1], robot_i[2], robot_i[3], robot_i[4], robot_i[5]
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
    o += 2 * nq
    vel, acc, jerk = robot_f[o:o + nv], robot_f[o + nv:o + 2 * nv], robot_f[o + 2 * nv:o + 3 * nv]
    o += 3 * nv
    ee_limits = robot_f[o:o + 3]
    lever = robot_f[o + 3]
    return (nq, nv, ee_joint, jtype, parent, idx_q, idx_v, support, cap_joint, limited, axes, placement_R,
            placement_t, ee_R, ee_t, cap_p0l, cap_p1l, radius, lower, upper, vel, acc, jerk, ee_limits, lever)


@numba.njit(cache=True)
def kinematics(q, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_joint, ee_R, ee_t,
               cap_joint, cap_p0l, cap_p1l, nv):  # pragma: no cover - compiled
    """``(oR, op, p_ee, R_ee, J6 (6, nv), p0, p1)`` at ``q``: joint placements, the
    end-effector's pose and LOCAL_WORLD_ALIGNED Jacobian, the capsules' end points."""
    nj = jtype.shape[0]
    oR, op = np.empty((nj, 3, 3)), np.empty((nj, 3))
    forward_kinematics(q, jtype, axes, parent, idx_q, placement_R, placement_t, oR, op)
    R_ee = matmul(oR[ee_joint], ee_R)
    p_ee = op[ee_joint] + matvec(oR[ee_joint], ee_t)
    J6 = np.empty((6, nv))
    frame_jacobian(p_ee, ee_joint, oR, op, axes, idx_v, support, J6)
    c = cap_joint.shape[0]
    p0, p1 = np.empty((c, 3)), np.empty((c, 3))
    for k in range(c):
        j = cap_joint[k]
        for r in range(3):
            p0[k, r] = op[j, r] + oR[j, r, 0] * cap_p0l[k, 0] + oR[j, r, 1] * cap_p0l[k, 1] + oR[j, r, 2] * cap_p0l[k, 2]
            p1[k, r] = op[j, r] + oR[j, r, 0] * cap_p1l[k, 0] + oR[j, r, 1] * cap_p1l[k, 1] + oR[j, r, 2] * cap_p1l[k, 2]
    return oR, op, p_ee, R_ee, J6, p0, p1


@numba.njit(cache=True, inline="always")
def previous_kinematics(kin_f, q, offsets, nj, nv, n_caps):  # pragma: no cover - compiled
    """Whether ``kin_f`` (a previous step's ``out_f``, laid out by ``offsets``) holds the
    kinematics at ``q`` (its q_next equal to ``q`` bit for bit), and ``kinematics``' tuple read
    from it (views; the step only reads them, and a step's output buffer never changes once
    written)."""
    nq = q.shape[0]
    found = kin_f.shape[0] == offsets[-1]
    if found:
        for i in range(nq):
            if kin_f[i] != q[i]:
                found = False
                break
    if not found:
        kin_f = np.zeros(offsets[-1])  # (never read: typed like the views)
    oR = kin_f[offsets[17]:offsets[18]].reshape((nj, 3, 3))
    op = kin_f[offsets[18]:offsets[19]].reshape((nj, 3))
    p_ee = kin_f[offsets[2]:offsets[3]]
    R_ee = kin_f[offsets[3]:offsets[4]].reshape((3, 3))
    J6 = kin_f[offsets[4]:offsets[5]].reshape((6, nv))
    p0 = kin_f[offsets[5]:offsets[6]].reshape((n_caps, 3))
    p1 = kin_f[offsets[6]:offsets[7]].reshape((n_caps, 3))
    return found, oR, op, p_ee, R_ee, J6, p0, p1


@numba.njit(cache=True, inline="always")
def joint_row(N, i, j, side):  # pragma: no cover - compiled
    """Row ``i`` of ``N``: joint ``j``'s velocity from below (``side`` 0: +1) or above (1: -1),
    0 elsewhere (element by element: a row view costs two reference counts)."""
    for k in range(N.shape[1]):
        N[i, k] = 0.0
    N[i, j] = 1.0 if side == 0 else -1.0


@numba.njit(cache=True)
def safety_net(q, qdot, dt_s, strategy, robot_i, robot_f, scene_i, reals, hum, before, before_start,
               qdot_prev):  # pragma: no cover - compiled
    """The step integrated (``pin.integrate``'s arithmetic) and re-checked: a step that would cross a
    limitation clear before it (``before``: each limitation's distances at ``q``, laid out by
    ``before_start``), or deepen one already violated, is scaled down by bisection. Only limitations
    the step can reach are re-checked (every distance is 1-Lipschitz in the arm's points, which move
    at most ``lever * sum |dq|``). Returns ``(q_next, oR, op, p_ee, R_ee, J6, p0, p1, scale)``: the
    configuration reached, ``kinematics`` there, and the share of ``qdot`` executed."""
    (nq, nv, ee_joint, jtype, parent, idx_q, idx_v, support, cap_joint, limited, axes, placement_R, placement_t,
     ee_R, ee_t, cap_p0l, cap_p1l, radius, lower, upper, vel, acc, jerk, ee_limits, lever) = unpack_robot(
        robot_i, robot_f)
    n_lim = scene_i.shape[0]
    n_before = before.shape[0]
    travel_sum, travel_max = 0.0, 0.0
    for j in range(nv):
        travel_sum += abs(qdot[j]) * dt_s
        travel_max = max(travel_max, abs(qdot[j]) * dt_s)
    reach_linear = lever * travel_sum + CROSSING_TOLERANCE_M
    reach_angular = travel_max + CROSSING_TOLERANCE_M
    checked = np.zeros(n_lim, dtype=np.bool_)
    if strategy != OFF:
        for con in range(n_lim):
            start, stop = before_start[con], before_start[con + 1]
            if stop > start:
                part_min = before[start:stop].min()
                checked[con] = part_min <= (reach_angular if scene_i[con, 0] == joint_range.KIND else reach_linear)
    net_scale, low, high = 1.0, 0.0, 1.0
    q_next = q.copy()
    after = np.empty(n_before)
    for attempt in range(27):
        # attempt 0: the full step; 1..25: bisection on its scale; 26: the scale found.
        scale = 1.0 if attempt == 0 else (low if attempt == 26 else 0.5 * (low + high))
        integrate(q, qdot * scale * dt_s, jtype, idx_q, idx_v, q_next)
        if strategy == OFF:  # the joints' own end stops
            for i in range(limited.shape[0]):
                iq = limited[i, 0]
                q_next[iq] = min(max(q_next[iq], lower[iq]), upper[iq])
        oR2, op2, p_ee2, R_ee2, J62, p02, p12 = kinematics(q_next, jtype, axes, parent, idx_q, idx_v, placement_R,
                                                           placement_t, support, ee_joint, ee_R, ee_t, cap_joint,
                                                           cap_p0l, cap_p1l, nv)
        if attempt == 26:
            net_scale = low
            break
        kin2 = (q_next, p_ee2, J62, oR2, op2, p02, p12, radius, cap_joint, axes, idx_v, support, lower, upper,
                limited, qdot_prev)
        admissible = True
        for con in range(n_lim):
            if not checked[con]:
                continue
            start, stop = before_start[con], before_start[con + 1]
            kind_distances(scene_i[con, 0], reals[con], scene_i[con, 1], kin2, hum, after[start:stop])
            for i in range(start, stop):
                if after[i] < min(before[i], 0.0) - CROSSING_TOLERANCE_M:
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
    return q_next, oR2, op2, p_ee2, R_ee2, J62, p02, p12, net_scale


@numba.njit(cache=True)
def arm_step(state_f, kin_f, v_desired, dt_s, strategy, flags, human_ahead_s, reference_f, robot_i, robot_f, scene_i,
             scene_f, human_f, settings_f, out_f, out_i):  # pragma: no cover - compiled
    """One step (see the module docstring); returns the status (``STATUS_*``)."""
    (nq, nv, ee_joint, jtype, parent, idx_q, idx_v, support, cap_joint, limited, axes, placement_R, placement_t,
     ee_R, ee_t, cap_p0l, cap_p1l, radius, lower, upper, vel, acc, jerk, ee_limits, lever) = unpack_robot(
        robot_i, robot_f)
    (max_speed, activation_m, buffer_m, buffer_rad, recovery_gain, width_m, width_rad, brake_share, null_weight,
     w_threshold, damping_max, orientation_gain, centering_gain, field_critical, field_influence, field_k_rep,
     field_max_rep, field_damping, evasion_gain) = settings_f[0], settings_f[1], settings_f[2], settings_f[3], \
        settings_f[4], settings_f[5], settings_f[6], settings_f[7], settings_f[8], settings_f[9], settings_f[10], \
        settings_f[11], settings_f[12], settings_f[13], settings_f[14], settings_f[15], settings_f[16], settings_f[17], \
        settings_f[18]
    ssm_params = settings_f[19:25]
    q = state_f[0:nq].copy()
    qdot_prev = state_f[nq:nq + nv].copy()
    qddot_prev = state_f[nq + nv:nq + 2 * nv].copy()
    u_prev = state_f[nq + 2 * nv:nq + 2 * nv + 3].copy()
    a_hand_prev = state_f[nq + 2 * nv + 3:nq + 2 * nv + 6].copy()
    v = v_desired.copy()
    R_ref = reference_f[0:9].reshape((3, 3))
    speed_cap = min(reference_f[9], max_speed, ee_limits[0])
    with_orientation, ssm, force_stop = (flags & FLAG_ORIENTATION) != 0, (flags & FLAG_SSM) != 0, \
        (flags & FLAG_STOP) != 0
    ssm_stop, protective_held = (flags & FLAG_PROTECTIVE) != 0, (flags & FLAG_PROTECTIVE_HELD) != 0
    joint_command = (flags & FLAG_JOINT_COMMAND) != 0
    ee_speed, ee_acc, ee_jerk = ee_limits[0], ee_limits[1], ee_limits[2]
    out_i[:OUT_I_HEADER] = 0  # (the row codes after it: written as far as the header counts them)
    out_f[:] = 0.0
    hp0, hp1, hr, hv0, hv1 = human_kind.unpack_human(human_f, human_ahead_s)
    hum = (hp0, hp1, hr, hv0, hv1)
    n_caps = cap_joint.shape[0]
    n_lim = scene_i.shape[0]
    # ---- 1. kinematics and task --------------------------------------------------------------
    offsets = output_layout(nq, nv, n_caps, jtype.shape[0])
    found, oR, op, p_ee, R_ee, J6, p0, p1 = previous_kinematics(kin_f, q, offsets, jtype.shape[0], nv, n_caps)
    if not found:
        oR, op, p_ee, R_ee, J6, p0, p1 = kinematics(q, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t,
                                                    support, ee_joint, ee_R, ee_t, cap_joint, cap_p0l, cap_p1l, nv)
    kin = (q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot_prev)
    speed = np.sqrt(np.sum(v * v))
    if speed > speed_cap and not joint_command:  # (a joint command: the speed rows cap its hand)
        v = v * (speed_cap / speed)
    J = np.ascontiguousarray(J6[:3])
    error = log3(matmul_nt(R_ref, R_ee)) if with_orientation else np.zeros(3)
    centering = np.zeros(nv)
    for i in range(limited.shape[0]):
        iq, iv = limited[i, 0], limited[i, 1]
        span = max(upper[iq] - lower[iq], 1e-6)
        centering[iv] = -centering_gain * (q[iq] - 0.5 * (lower[iq] + upper[iq])) / span
    M, c = task_mapping(J, np.ascontiguousarray(J6[3:]), error, centering, damping_max, w_threshold,
                        orientation_gain, 0.5 * vel, with_orientation)
    # ---- 2. rows -----------------------------------------------------------------------------
    reals = scene_f.copy() if strategy == REACTIVE else scene_f  # (the field's own critical distance below)
    n_human = hr.shape[0]
    max_lim_rows, n_before = 0, 0
    before_start = np.zeros(n_lim + 1, dtype=np.int64)
    for con in range(n_lim):
        kind = scene_i[con, 0]
        if strategy == REACTIVE and kind == human_kind.KIND:
            reals[con, 0] = field_critical  # the field keeps its own critical distance
        size = kind_count(kind, reals[con], scene_i[con, 1], n_caps, limited.shape[0], n_human)
        if size < 0:
            out_i[I_STATUS] = STATUS_UNKNOWN_KIND
            return STATUS_UNKNOWN_KIND
        before_start[con + 1] = before_start[con] + size
        max_lim_rows += size
    n_before = before_start[n_lim]
    dist, A, rate = np.empty(max_lim_rows), np.empty((max_lim_rows, nv)), np.empty(max_lim_rows)
    angular, tag = np.empty(max_lim_rows, dtype=np.bool_), np.empty((max_lim_rows, 3), dtype=np.int64)
    # how fast the limitation's curvature and the row's point's own motion draw the arm toward
    # each row [m/s^2] (``limitations/rows.py``)
    pull, drift = np.zeros(max_lim_rows), np.zeros(max_lim_rows)
    before = np.empty(n_before)
    out = (dist, A, rate, angular, tag, pull, drift)
    # A person walking at the arm is watched from farther: their speed times the time the arm
    # needs to stand still from its motion now (every joint braked together, ramps included).
    walk_m = 0.0
    for h in range(n_human):
        walk_m = max(walk_m, np.sqrt(hv0[h, 0] ** 2 + hv0[h, 1] ** 2 + hv0[h, 2] ** 2),
                     np.sqrt(hv1[h, 0] ** 2 + hv1[h, 1] ** 2 + hv1[h, 2] ** 2))
    if walk_m > 0.0:
        walk_m *= arm_stop_time(qdot_prev, qddot_prev, u_prev, acc, jerk, EE_AXIS_SHARE * ee_acc,
                                EE_AXIS_SHARE * ee_jerk, dt_s)
    # Metric limitations (zones, table, reach) are watched from ``activation_m``, or from as far
    # as the plan needs to brake the arm's fastest capsule end (its speed now, at ``brake_share``
    # of the hand's per-axis box) when that is farther: from 0.15 m the iiwa's hand driven down
    # at 0.5 m/s had the last of its braking done beyond the limits (its plan brakes in 0.25 m).
    fastest = fastest_capsule_end(oR, op, axes, parent, idx_v, cap_joint, p0, p1, qdot_prev)
    metric_m = max(activation_m, stop_distance(fastest, 0.0, brake_share * EE_AXIS_SHARE * ee_acc,
                                               brake_share * EE_AXIS_SHARE * ee_jerk, dt_s) + fastest * dt_s)
    m = 0
    for con in range(n_lim):
        kind = scene_i[con, 0]
        m = kind_rows(kind, reals[con], scene_i[con, 1], con, kin, hum,
                      reals[con, 1] + walk_m if kind == human_kind.KIND else metric_m, out, m,
                      before[before_start[con]:before_start[con + 1]])
    is_human = np.zeros(m, dtype=np.bool_)
    separation = np.full(m, np.inf)  # the human rows' capsule distance [m]
    human_skip, human_con = 1, -1
    for i in range(m):
        is_human[i] = scene_i[tag[i, 0], 0] == human_kind.KIND
        if is_human[i]:
            separation[i] = dist[i] + reals[tag[i, 0], 0]
    for con in range(n_lim):
        if scene_i[con, 0] == human_kind.KIND:
            human_skip, human_con = min(scene_i[con, 1], n_caps), con
    # ---- 3. the strategy's target ------------------------------------------------------------
    q0 = v.copy() if joint_command else matvec(M, v) + c
    Z = null_basis(J)
    nz = 3 + Z.shape[1]
    B = np.empty((nv, nz))
    B[:, :3] = M
    B[:, 3:] = Z / null_weight
    stopped = False
    protective = False
    evading = False
    evades = strategy == ANTICIPATIVE and evasion_gain > 0.0 and n_human > 0
    if evades or strategy == REACTIVE:
        if human_con >= 0:  # the pair from the human rows' distances (every pair measured there)
            d_min, capsule, _, pr, ph = human_kind.closest_of_rows(
                before[before_start[human_con]:before_start[human_con + 1]], human_skip, p0, p1, radius, hp0, hp1, hr)
        else:
            d_min, capsule, _, pr, ph = human_kind.closest_axis_pair(p0, p1, radius, human_skip, hp0, hp1, hr)
    if evades:
        # Next to a person the command is the user's plus paper 2's repulsion at the arm's
        # closest point (``evasion_gain`` of it): the arm moves its body out of the way as the
        # field does, and the rows below still keep every limitation.
        # Chan and Dubey's weights on the joints moving toward a limit (paper 2's repulsion first,
        # unweighted, says which): the evasion leaves joints near their limits alone rather
        # than wedging the arm against several limits at once.
        J_cp, push = field_push(d_min, capsule, pr, ph, nv, cap_joint, oR, op, axes, idx_v, support,
                                field_critical, field_influence, field_k_rep, field_max_rep)
        unweighted = weighted_least_norm(J_cp, push, field_damping, np.ones(nv))
        scale = limit_scale(q, lower, upper, limited, nv)
        for i in range(limited.shape[0]):
            iq, iv = limited[i, 0], limited[i, 1]
            if unweighted[iv] * (q[iq] - 0.5 * (lower[iq] + upper[iq])) <= 0.0:
                scale[iv] = 1.0  # moving toward the middle: free
        repulsion = weighted_least_norm(J_cp, push, field_damping, scale)
        for j in range(nv):
            q0[j] += evasion_gain * repulsion[j]
            evading = evading or repulsion[j] != 0.0
    if strategy == REACTIVE:
        q0, stopped = field_velocity(J, np.zeros(3) if joint_command else v, d_min, capsule, pr, ph, cap_joint, oR,
                                     op, axes, idx_v, support, field_critical, field_influence, field_k_rep,
                                     field_max_rep, field_damping)
        if joint_command and not stopped:
            q0 += v
        B = np.eye(nv)
    elif strategy == OFF or joint_command:
        B = np.eye(nv)
    bounds = np.empty(m)  # the plan's bounds
    keep = np.ones(m, dtype=np.bool_)
    safe_bounds = np.empty(m)  # the safety bounds: the full motion limits
    safe_keep = np.ones(m, dtype=np.bool_)
    recovering = np.zeros(m, dtype=np.bool_)
    ramp = np.zeros(m)
    ee_velocity_prev = matvec(J, qdot_prev)
    ee_speed_prev = np.max(np.abs(ee_velocity_prev))  # its fastest axis: the box is per axis
    # The command's cap bounds what the user asks for; from a person walking at the arm the
    # anticipative arm may flee faster, at the share of the robot's own end-effector speed the
    # filter plans the hand's motion with (``EE_MOTION_SHARE``; at the full speed a hand fleeing
    # at the limit had no room for its jerk ramp when the person stopped, and gave up
    # smoothness; at the command's cap a retreat went at 0.5 m/s from people coming at 1-2 m/s,
    # at ``brake_share`` of the robot's speed the iiwa's too: breaches the campaign's escape
    # search found avoidable).
    flee_cap = max(speed_cap, EE_MOTION_SHARE * ee_speed)
    # The bounds brake within the motion box's own limits (``MOTION_MARGIN`` inside the robot's):
    # with the full limits a safety bound could ask for 1e-4 more than the box gives, and on an
    # AMD EPYC's rounding an iiwa release at its extended reach gave up smoothness for that
    # (2 steps, jerk 1.02 times the limit: 1.4e-6 rad/s past the box).
    brake_factor = limitation_bounds(dist, A, rate, angular, separation, pull, drift, m, q0, qdot_prev, qddot_prev,
                                     ee_speed_prev, dt_s, MOTION_MARGIN * acc, MOTION_MARGIN * jerk, vel,
                                     MOTION_MARGIN * ee_acc, MOTION_MARGIN * ee_jerk, brake_share, buffer_m,
                                     buffer_rad, recovery_gain, width_m, width_rad, speed_cap, flee_cap,
                                     ssm, ssm_params, bounds, keep, safe_bounds, safe_keep, recovering,
                                     ramp)
    # Fleeing: a human row closing (kept). Once nobody closes, a hand still faster than the
    # command's cap slows down to it at the plan's share of its deceleration (the cap falls from
    # the hand's speed now); held at the flee cap, the hand went on at 0.83 m/s beside a person
    # who had stopped, for seconds, and wound the arm's joints into their limits.
    hand_speed = np.sqrt(ee_velocity_prev[0] ** 2 + ee_velocity_prev[1] ** 2 + ee_velocity_prev[2] ** 2)
    fleeing = False
    if strategy == ANTICIPATIVE:
        for i in range(m):
            if is_human[i] and keep[i] and rate[i] < 0.0:
                fleeing = True
    if ssm_stop and n_human > 0 and strategy != OFF:
        # Protective stop: the separation below ISO/TS 15066's S at the arm's approach speed.
        # A stop already under way holds until S at the speed cap, the speed the arm may take
        # when it goes again: a stopped arm's S is the smallest, so without that it would go
        # and stop again every few steps where the separation hovers at S.
        approach = speed_cap if protective_held else 0.0
        for i in range(m):
            if is_human[i]:
                toward = 0.0
                for j in range(nv):
                    toward -= A[i, j] * qdot_prev[j]
                approach = max(approach, toward)
        for i in range(m):
            if is_human[i] and separation[i] < separation_kernel(approach, ssm_params):
                protective = True
    if strategy == STOP:
        for i in range(m):
            if keep[i]:
                rate_q0 = 0.0
                for j in range(nv):
                    rate_q0 += A[i, j] * q0[j]
                if rate_q0 < bounds[i] - 1e-12:
                    stopped = True
    if stopped or protective or force_stop:
        q0 = np.zeros(nv)
    if strategy == STOP or protective or force_stop:
        # The stop baseline, the protective stop and the watchdog's stop never move away from a limitation
        # (a person walking at the arm meets an arm that brakes and holds still): the bounds ask
        # at most for standstill.
        for i in range(m):
            bounds[i] = min(bounds[i], 0.0)
            safe_bounds[i] = min(safe_bounds[i], 0.0)
    # ---- 4. the rows the filter keeps ----------------------------------------------------------
    capacity = 2 * m + 4 * nv + 6 + SPEED_CUTS
    N = np.empty((capacity, nv))  # (every row written in full before it is read)
    b = np.empty(capacity)
    ramp_b = np.zeros(capacity)  # the recoveries' first easing
    group = np.empty(capacity, dtype=np.int64)
    code = np.empty(capacity, dtype=np.int64)
    count = 0
    if strategy != OFF:
        for i in range(m):
            plan, safety = bounds[i], safe_bounds[i]
            with_plan, with_safety = keep[i], safe_keep[i]
            if strategy == REACTIVE and is_human[i]:
                if not ssm:
                    continue  # the field itself answers the human
                safety = -approach_speed_kernel(separation[i], ssm_params)  # its SSM layer only
                with_plan, with_safety = False, True
            row = row_code(tag[i, 0], tag[i, 1], tag[i, 2])
            # (element by element: a row view costs two atomic reference counts, per row)
            if with_safety:
                for j in range(nv):
                    N[count, j] = A[i, j]
                b[count], code[count], ramp_b[count] = safety, row, ramp[i]
                # A person standing where the arm already is: its drift out eases before the
                # motion limits give way (a joint limit or a zone keeps its hard recovery: eased,
                # the iiwa's drive into joint 2's lower limit at 1 kHz gave up smoothness 49 times).
                recovery = recovering[i] and is_human[i] and safety > 0.0
                group[count] = RECOVERY if recovery else LIMITATION
                count += 1
            if with_plan and (plan > safety or not with_safety):
                for j in range(nv):
                    N[count, j] = A[i, j]
                b[count], group[count], code[count] = plan, PLAN, row
                count += 1
    for j in range(nv):
        for side in range(2):
            joint_row(N, count, j, side)
            b[count], group[count] = -vel[j], VELOCITY
            code[count] = row_code(OWNER_VELOCITY, j, side)
            count += 1
    lo, hi = np.empty(nv), np.empty(nv)
    motion_box(qdot_prev, qddot_prev, acc, jerk, vel, dt_s, lo, hi)
    for j in range(nv):
        for side in range(2):
            if (side == 0 and lo[j] <= -vel[j]) or (side == 1 and hi[j] >= vel[j]):
                continue  # the speed limit is the stricter
            joint_row(N, count, j, side)
            b[count], group[count] = (lo[j] if side == 0 else -hi[j]), MOTION
            code[count] = row_code(OWNER_MOTION, j, side)
            count += 1
    # The end-effector's acceleration and jerk, per axis (each / sqrt(3): the norm holds), on
    # the part the joints' acceleration gives it (J qddot, from the previous joint velocity and
    # acceleration seen through today's Jacobian); EE_MOTION_SHARE leaves the rest to the
    # motion's curvature (the executed acceleration is J qddot + dJ/dt qdot).
    hand_rows = count
    ee_lo, ee_hi = np.empty(3), np.empty(3)
    motion_box(ee_velocity_prev, matvec(J, qddot_prev), np.full(3, EE_AXIS_SHARE * ee_acc),
               np.full(3, EE_AXIS_SHARE * ee_jerk), np.full(3, np.inf), dt_s, ee_lo, ee_hi)
    for r in range(3):
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            for j in range(nv):
                N[count, j] = sign * J[r, j]
            b[count], group[count] = (ee_lo[r] if side == 0 else -ee_hi[r]), HAND
            code[count] = row_code(OWNER_EE_MOTION, r, side)
            count += 1
    # ---- 5. filter -----------------------------------------------------------------------------
    cap = ee_speed if strategy == OFF else (flee_cap if fleeing else speed_cap)
    if strategy == ANTICIPATIVE and not fleeing and hand_speed > speed_cap:
        cap = min(flee_cap, max(speed_cap, hand_speed - brake_share * EE_AXIS_SHARE * ee_acc * dt_s))
    ahead_cap = cap
    lead = np.zeros(3)
    if strategy != OFF:
        # Toward the cap the hand's acceleration must ramp down at its jerk limit before it
        # gets there, as ``motion_box`` asks of a joint toward its speed limit: this step's cap
        # is at most the speed from which that ramp still ends at the cap (the hand levels off
        # a little under it, by half the speed its curving path loses per step at a constant
        # joint velocity: ~2e-4 of it on the panda at 2 ms).
        room = cap - hand_speed
        if room > 0.0:
            cap = min(cap, hand_speed + ramp_acceleration(room, EE_AXIS_SHARE * ee_jerk, dt_s) * dt_s)
        # And in every direction (a turning hand): the cap bounds the velocity the hand reaches
        # once its acceleration has ramped down, per axis ``v' + a' |a'| / 2j + a' dt``, ``|a'|``
        # at most the previous step's plus a jerk step (``filter_rows``'s ``lead``).
        ee_acceleration_prev = matvec(J, qddot_prev)
        for r in range(3):
            lead[r] = abs(ee_acceleration_prev[r]) / (2.0 * EE_AXIS_SHARE * ee_jerk * dt_s) + 1.0
    qdot, violation, level, rows = filter_rows(q0, B, N, b, ramp_b, group, count, J, cap, ee_speed,
                                               ee_velocity_prev, lead, ahead_cap)
    if level == LEVEL_SMOOTHNESS:
        # The hand's box is its limits' ball inscribed: before the motion limits give way, the
        # same solve without the box, kept if the hand stays within the ball (``within_hand_ball``);
        # else the first solve again (its speed cuts were overwritten).
        box = b[hand_rows:hand_rows + 6].copy()
        b[hand_rows:hand_rows + 6] = -np.inf
        qdot_ball, violation_ball, level_ball, rows_ball = filter_rows(q0, B, N, b, ramp_b, group, count, J, cap,
                                                                       ee_speed, ee_velocity_prev, lead, ahead_cap)
        b[hand_rows:hand_rows + 6] = box
        if level_ball == LEVEL_EXACT and within_hand_ball(matvec(J, qdot_ball - qdot_prev), matvec(J, qddot_prev),
                                                          dt_s, ee_acc, ee_jerk):
            qdot, violation, level, rows = qdot_ball, violation_ball, level_ball, rows_ball
        else:
            qdot, violation, level, rows = filter_rows(q0, B, N, b, ramp_b, group, count, J, cap, ee_speed,
                                                       ee_velocity_prev, lead, ahead_cap)
    # The solver meets each row to its tolerance in its own units (rows scaled to unit length in
    # the task's coordinates), which through a task mapping near a singularity is up to ~1e-8
    # rad/s of a joint's velocity: a few 1e-4 of a jerk step at 1 kHz. The joints' speed limits
    # (always hard) and, when nothing gave way, their motion box are bounds on one joint each:
    # a joint beyond one by more than rounding (``ROUNDING_RAD_S``, 1e-8 of a jerk step) is put back
    # on it (the change is that small; the other rows move by as little; clamping every excess
    # moved paper 2's exp1 on the panda at 275 Hz onto 3 steps that gave up smoothness, against
    # 0: the plant, ``rate_limiter.follow_rate_limited``, takes a rounding's change as none).
    if level != LEVEL_STOPPED:
        for j in range(nv):
            if level == LEVEL_EXACT and (qdot[j] < lo[j] - ROUNDING_RAD_S or qdot[j] > hi[j] + ROUNDING_RAD_S):
                qdot[j] = min(max(qdot[j], lo[j]), hi[j])
            if abs(qdot[j]) > vel[j] + ROUNDING_RAD_S:
                qdot[j] = min(max(qdot[j], -vel[j]), vel[j])
    for i in range(count, rows):
        code[i] = row_code(OWNER_SPEED, 0, 0)
    # ---- 6. integrate and re-check --------------------------------------------------------------
    q_next, oR2, op2, p_ee2, R_ee2, J62, p02, p12, net_scale = safety_net(q, qdot, dt_s, strategy, robot_i, robot_f,
                                                                       scene_i, reals, hum, before, before_start,
                                                                       qdot_prev)
    qdot_exec = qdot * net_scale
    # ---- 7. outputs and the next step's state ---------------------------------------------------
    v_executed = (p_ee2 - p_ee) / dt_s
    out_f[offsets[0]:offsets[1]] = q_next
    out_f[offsets[1]:offsets[2]] = qdot_exec
    out_f[offsets[2]:offsets[3]] = p_ee2
    out_f[offsets[3]:offsets[4]] = R_ee2.ravel()
    out_f[offsets[4]:offsets[5]] = J62.ravel()
    out_f[offsets[5]:offsets[6]] = p02.ravel()
    out_f[offsets[6]:offsets[7]] = p12.ravel()
    out_f[offsets[7]:offsets[8]] = matvec(J, qdot_exec)
    out_f[offsets[8]:offsets[9]] = v_executed
    robot_point, human_point = np.empty(3), np.empty(3)
    kin_next = (q_next, p_ee2, J62, oR2, op2, p02, p12, radius, cap_joint, axes, idx_v, support, lower, upper,
                limited, qdot_prev)
    out_f[offsets[9]] = human_kind.closest_pair(human_skip, kin_next, hum, robot_point, human_point)
    out_f[offsets[10]:offsets[11]] = robot_point
    out_f[offsets[11]:offsets[12]] = human_point
    out_f[offsets[12]] = net_scale
    worst, worst_code, relaxed_rows, motion_violation, joint_violation = 0.0, -1, 0, 0.0, 0.0
    n_binding, n_motion = 0, 0
    codes = out_i[OUT_I_HEADER:]
    motion_codes = np.empty(rows, dtype=np.int64)
    tolerance = 1e-9
    for i in range(rows):
        rate_i = 0.0
        for j in range(nv):
            rate_i += N[i, j] * qdot[j]
        slack = rate_i - (b[i] - violation[i])
        if is_motion(group[i]):
            motion_violation = max(motion_violation, violation[i])
            if group[i] == MOTION:
                joint_violation = max(joint_violation, violation[i])
            if slack <= BINDING_TOLERANCE or violation[i] > tolerance:
                motion_codes[n_motion] = code[i]
                n_motion += 1
            continue
        if group[i] == PLAN:  # the plan's margin: binding if the command slides on it
            if rate_i - b[i] <= BINDING_TOLERANCE and n_binding < codes.shape[0]:
                codes[n_binding] = code[i]
                n_binding += 1
            continue
        if violation[i] > tolerance:
            relaxed_rows += 1
            if violation[i] > worst:
                worst, worst_code = violation[i], code[i]
        if slack <= BINDING_TOLERANCE and n_binding < codes.shape[0]:
            codes[n_binding] = code[i]
            n_binding += 1
    for i in range(n_motion):
        if n_binding + i < codes.shape[0]:
            codes[n_binding + i] = motion_codes[i]
    out_f[offsets[13]] = worst
    out_f[offsets[14]] = motion_violation
    out_f[offsets[15]] = brake_factor
    out_i[I_STATUS] = STATUS_DONE
    out_i[I_LEVEL] = level
    user_moves = speed > 0.0 and not (stopped or protective or force_stop)
    commanded = np.sqrt(np.sum(qdot ** 2) if joint_command else np.sum(matvec(J, qdot) ** 2))
    out_i[I_STOPPED] = int(stopped or protective or force_stop or level == LEVEL_STOPPED or (
        user_moves and commanded <= 1e-6))
    out_i[I_BINDING] = n_binding
    out_i[I_RELAXED] = relaxed_rows if level in (LEVEL_RELAXED, LEVEL_APPROACH_NOTHING) else 0
    out_i[I_WORST] = worst_code
    out_i[I_MOTION_LIMITED] = int(n_motion > 0)
    out_i[I_MOTION_COUNT] = n_motion
    if level >= 1 and joint_violation > tolerance:
        out_i[I_SMOOTHNESS] = GAVE_WAY_JOINTS
    elif level >= 1 and motion_violation > tolerance:
        out_i[I_SMOOTHNESS] = GAVE_WAY_HAND
    elif net_scale < 1.0:
        out_i[I_SMOOTHNESS] = GAVE_WAY_NET
    else:
        out_i[I_SMOOTHNESS] = 0
    out_i[I_PROTECTIVE] = int(protective)
    out_i[I_EVADING] = int(evading)
    acceleration_ratio = 0.0
    for j in range(nv):
        acceleration_ratio = max(acceleration_ratio, abs(qdot_exec[j] - qdot_prev[j]) / dt_s / acc[j])
    out_f[offsets[16]] = acceleration_ratio
    out_f[offsets[17]:offsets[18]] = oR2.ravel()
    out_f[offsets[18]:offsets[19]] = op2.ravel()
    # The hand's executed path against its own limits (what the box on ``J qddot`` cannot see):
    # reported, never silent.
    a_hand = (v_executed - u_prev) / dt_s
    hand_acceleration_ratio = np.sqrt(np.sum(a_hand ** 2)) / ee_acc
    hand_jerk_ratio = np.sqrt(np.sum(((a_hand - a_hand_prev) / dt_s) ** 2)) / ee_jerk
    out_f[offsets[19]] = hand_acceleration_ratio
    out_f[offsets[19] + 1] = hand_jerk_ratio
    out_i[I_HAND_OVER] = int(max(hand_acceleration_ratio, hand_jerk_ratio) > OVER_LIMIT_RATIO)
    state_f[0:nq] = q_next
    state_f[nq:nq + nv] = qdot_exec
    state_f[nq + nv:nq + 2 * nv] = (qdot_exec - qdot_prev) / dt_s
    state_f[nq + 2 * nv:nq + 2 * nv + 3] = v_executed
    state_f[nq + 2 * nv + 3:nq + 2 * nv + 6] = a_hand
    return STATUS_DONE
