"""Each limitation row's bounds on the arm's approach rate, compiled: the plan's (a share of
the motion limits) and the safety's (the full limits), from the braking model of
``braking.py``, ISO/TS 15066's separation for a person walking at the arm, and SSM's speed
limit. ``step_kernel.arm_step`` turns them into the filter's ``PLAN``, ``LIMITATION`` and
``RECOVERY`` rows (``joint_filter``).
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.braking import beyond_ramp, row_capacity, safe_speed, stop_time
from cobotsafety.arm.motion_box import EE_AXIS_SHARE
from cobotsafety.arm.ssm import approach_speed_kernel

#: The least share of a row's deceleration a brake keeps when the limitation's curvature pulls
#: the arm toward it (beyond it, the sliding is faster than the limits can hold on that curve).
PULL_FLOOR = 0.25
#: An approach slower than this [m/s or rad/s] is at rest: the plan's whole-arm stop (its
#: deceleration scaled by the approach's speed) is not applied to it. Below ~1e-103 the braking
#: model's ``decel^3 / jerk^2`` underflows to 0 / 0, and the compiled step raised
#: ZeroDivisionError on an iiwa joint approaching its limit at 5e-312 rad/s while another moved
#: (``tests/test_limitation_bounds_rest.py``); 1e-100 is far below any speed the arm resolves
#: (its rounding, ``ROUNDING_RAD_S``, is 1e-12) and far above that underflow.
AT_REST = 1e-100


@numba.njit(cache=True)
def limitation_bounds(dist, A, rate, angular, separation, pull, drift, count, q0, qdot_prev, qddot_prev, ee_speed_prev,
                      dt_s, acc, jerk, vel, ee_acc, ee_jerk, brake_share, buffer_m, buffer_rad, recovery_gain,
                      width_m, width_rad, speed_cap, retreat_cap, ssm, ssm_params, plan, keep_plan, safety,
                      keep_safety, recovering, ramp):  # pragma: no cover - compiled
    """Each row's bounds ``b`` of ``a . qdot >= b``: the plan's (``brake_share`` of the motion
    limits, paper 1's damped zone when a width is set) into ``plan``, and the safety's (the full
    motion limits) into ``safety``; ``keep_*`` False for rows no velocity within the joints'
    limits can break; ``recovering`` True for a safety bound that drifts out of a limitation
    with nothing walking at it (a human's: the filter's ``RECOVERY`` rows), and ``ramp`` the
    retreat it can grow to this step (its braking capacity). Returns the largest factor by
    which a safety bound had to exceed the motion limits (1: none).

    Outside the buffer: approach no faster than the arm can brake before the limitation from
    its approach speed and acceleration now (``braking.safe_speed``: beyond reach, with the least
    excess over the motion limits that still stops before it), with what the joints can give
    along the row from their accelerations now (``braking.row_capacity``: a joint already at its
    limit adds no jerk; at most the end-effector's limits for metric rows). The plan brakes as part
    of the whole arm's stop (every joint's velocity scaled down together, as fast as the
    bottleneck joint allows), so that budgets of rows binding at once are met by one braking;
    a moving human's rows keep the capacity along their own normal (a retreat is not a stop).
    Inside the buffer: drift out at ``recovery_gain`` times the intrusion (never deeper). A
    person walking at the arm (``rate`` < 0, their approach speed ``v_h``): the plan retreats
    as they come (their approach added to the arm's), but the safety bound is ISO/TS 15066's
    separation (``S = v_h (T_r + T_s) + ...``): the arm's own approach no faster than it can
    end within the gap less how far the person walks meanwhile (``braking.stop_time``), and
    inside the buffer braking toward standstill at the full limits: the arm need not outrun a
    person, it must be able to stop for them. With SSM the arm's own approach to a human
    (rows with a finite ``separation`` [m], the capsules' distance) is also at most ISO/TS
    15066's speed for that separation. A retreat never asks for more than the speed cap, from a
    person walking at the arm no more than ``retreat_cap``. A
    limitation whose curvature pulls the sliding arm toward it (``pull`` [m/s^2] > 0 at the
    arm's velocity now: the extended reach) adds that pull to the approach's acceleration and
    takes it from the deceleration the brake has along the row. The row's point's own drift
    (``drift``: a turning link carries its points on a curve) is the curvature of the motion the
    plan leaves ``1 - brake_share`` of the limits for; the safety bound, at the full limits,
    counts it with the pull."""
    nv = A.shape[1]
    worst_factor = 1.0
    stop_decel, stop_jerk = np.inf, np.inf
    for j in range(nv):
        if abs(qdot_prev[j]) > 1e-9:
            stop_decel = min(stop_decel, acc[j] / abs(qdot_prev[j]))
            stop_jerk = min(stop_jerk, jerk[j] / abs(qdot_prev[j]))
    if ee_speed_prev > 1e-9:  # the hand stops with the arm: within its own box too (per axis)
        stop_decel = min(stop_decel, EE_AXIS_SHARE * ee_acc / ee_speed_prev)
        stop_jerk = min(stop_jerk, EE_AXIS_SHARE * ee_jerk / ee_speed_prev)
    for i in range(count):
        rate_now, rate_accel, decel, jerk_n, jerk_all, reach = row_capacity(A, i, qdot_prev, qddot_prev, acc, jerk,
                                                                             vel)
        own_speed, own_accel = -rate_now, -rate_accel
        beyond_slope, beyond_start = beyond_ramp(A, i, qddot_prev, acc, jerk, decel, rate_accel)
        beyond_all = jerk_all
        if rate[i] < 0.0:
            # A person walking at the arm: ISO/TS 15066's bound multiplies their speed by the
            # time the arm's approach takes to end; with the ramp from the joints' state now that
            # time jumps as joints reach their limits mid-brake, and the bound fell faster than
            # the arm could follow (``test_a_person_faster_than_the_arm...``): their rows keep
            # every joint's jerk, as before ``row_capacity``.
            jerk_n = jerk_all
        if not angular[i]:  # within the end-effector's box along any direction (per axis / sqrt(3))
            decel = min(decel, EE_AXIS_SHARE * ee_acc)
            jerk_n = min(jerk_n, EE_AXIS_SHARE * ee_jerk)
            beyond_all = min(beyond_all, EE_AXIS_SHARE * ee_jerk)
        # What draws the arm toward the limitation at its speed now: part of its approach's
        # acceleration, and held against by the brake while the arm slides on. The plan counts
        # the limitation's curvature; the safety bound the row's point's drift as well.
        plan_accel, plan_decel = own_accel, decel
        if pull[i] > 0.0:
            plan_accel += pull[i]
            plan_decel = max(decel - pull[i], PULL_FLOOR * decel)
        toward = max(pull[i] + drift[i], 0.0)
        own_accel += toward
        decel = max(decel - toward, PULL_FLOOR * decel)
        keep_plan[i], keep_safety[i], recovering[i], ramp[i] = False, False, False, 0.0
        plan[i], safety[i] = -np.inf, -np.inf
        if decel <= 0.0 or jerk_n <= 0.0:
            continue  # a row the joints cannot move: no half-space on the command
        plan_jerk = jerk_n
        if rate[i] == 0.0 and own_speed > AT_REST:
            plan_decel = min(plan_decel, own_speed * stop_decel)
            plan_jerk = min(plan_jerk, own_speed * stop_jerk)
        plan_decel *= brake_share
        plan_jerk *= brake_share
        gap = dist[i] - (buffer_rad if angular[i] else buffer_m)
        human_closing = -min(rate[i], 0.0)
        cap = 0.5 * reach if angular[i] else (retreat_cap if human_closing > 0.0 else speed_cap)
        if gap <= 0.0:
            plan_bound = -recovery_gain * gap + human_closing
            # The approach speed after one step braking at the row's limits.
            braked = own_speed + max(own_accel - jerk_n * dt_s, -decel) * dt_s
            if human_closing > 0.0:  # inside a moving person's distance: brake to standstill at the limits
                safety_bound = -max(braked, 0.0)
            else:
                # Out at ``recovery_gain`` times the intrusion; when the motion limits leave no
                # room for that, the filter eases it to what the row's braking capacity lets the
                # retreat grow to this step (``ramp``), then to approach nothing.
                safety_bound = -recovery_gain * gap
                recovering[i] = True
                ramp[i] = -braked
        else:
            # (with a pull, the command's rate next step is ``a . qdot`` less it:
            # the braking model starts from the rate the command gives and the pull on top)
            speed_plan = own_speed - max(pull[i], 0.0) * dt_s + human_closing
            speed_now = own_speed - toward * dt_s + human_closing
            allowed, _ = safe_speed(gap, speed_plan, plan_accel, plan_decel, plan_jerk, dt_s, reach + human_closing)
            plan_bound = human_closing - allowed
            if allowed == np.inf:
                safety_bound = -np.inf  # viable at full speed with less: with the full limits too
            elif human_closing > 0.0:
                # ISO/TS 15066's separation: the arm must be able to stand still before the
                # person, still walking at it, reaches the limitation; it need not outrun them
                # (the plan above still retreats as fast as they come, within the limits).
                # The person walks on while the arm's approach along this row ends (from the
                # fastest it may take next step, braking at the row's limits).
                fastest_next = max(own_speed, 0.0) + decel * dt_s
                room = gap - human_closing * stop_time(fastest_next, own_accel, decel, jerk_n, dt_s)
                allowed, factor = safe_speed(room, own_speed, own_accel, decel, jerk_n, dt_s, reach, beyond_all,
                                             beyond_slope, beyond_start)
                worst_factor = max(worst_factor, factor)
                safety_bound = -allowed
            else:
                allowed, factor = safe_speed(gap, speed_now, own_accel, decel, jerk_n, dt_s, reach + human_closing,
                                             beyond_all, beyond_slope, beyond_start)
                worst_factor = max(worst_factor, factor)
                safety_bound = human_closing - allowed
            width = width_rad if angular[i] else width_m
            if width > 0.0 and gap < width:
                desired = rate[i]
                for j in range(nv):
                    desired += A[i, j] * q0[j]
                if desired < 0.0:
                    plan_bound = max(plan_bound, gap / width * desired - min(rate[i], 0.0))
        if ssm and np.isfinite(separation[i]):
            limit = -approach_speed_kernel(separation[i], ssm_params)
            plan_bound, safety_bound = max(plan_bound, limit), max(safety_bound, limit)
        plan[i], safety[i] = min(plan_bound, cap), min(safety_bound, cap)
        keep_plan[i] = plan[i] > -reach - 1e-12
        keep_safety[i] = safety[i] > -reach - 1e-12
    return worst_factor

