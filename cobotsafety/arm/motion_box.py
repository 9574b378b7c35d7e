"""The motion box: the joint (or end-effector) velocities the next step may take from the
previous one within the acceleration and jerk limits, and the shares of the limits the filter
plans with.

``motion_box`` bounds each coordinate's next velocity: within ``acc dt`` of the previous one and
``jerk dt^2`` of its extrapolation at the previous acceleration, and toward the speed limit no
faster than the acceleration can still ramp down at the jerk limit (``ramp_acceleration``).
``step_kernel.arm_step`` gives it the joints' limits and the end-effector's (per axis).
"""

from __future__ import annotations

import math

import numba

from cobotsafety.arm.braking import positive_root

#: The share of the end-effector's acceleration and jerk limits the filter plans with.
EE_MOTION_SHARE = 0.9
#: Its share per axis: the filter bounds the end-effector's acceleration and jerk per axis
#: (a box), each axis at ``1 / sqrt(3)`` of the share so that the norm holds; braking along any
#: direction is planned within that box.
EE_AXIS_SHARE = EE_MOTION_SHARE / math.sqrt(3.0)
#: The motion box is planned this far inside the acceleration and jerk limits, so that the
#: solver's tolerance (1e-9 on rows scaled to unit length) never pushes a command past them.
MOTION_MARGIN = 1.0 - 1e-4
#: A joint velocity within this [rad/s] of its motion box or speed limit is on it: the solver's
#: rounding. ``step_kernel.arm_step`` puts a joint back on a bound only past it; the plant
#: (``rate_limiter.follow_rate_limited``) takes a limiter's change this small as none.
ROUNDING_RAD_S = 1e-12


@numba.njit(cache=True)
def ramp_acceleration(room, jerk, dt_s):  # pragma: no cover - compiled
    """The largest acceleration toward a speed limit ``room`` [m/s or rad/s] away (> 0) from
    which the acceleration can still ramp down to zero at ``jerk`` before the limit, in steps
    of ``dt_s``: the root of ``a^2 / 2j + 1.5 a dt = room`` (``v' = v + a dt``, then the ramp's
    ``a'^2 / 2j + a' dt / 2``)."""
    return positive_root(jerk, 1.5 * dt_s, room)


@numba.njit(cache=True)
def motion_box(qdot_prev, qddot_prev, acc, jerk, vel, dt_s, lo, hi):  # pragma: no cover - compiled
    """The velocities the next step may take [rad/s or m/s]: within ``acc dt`` of the previous
    velocity and ``jerk dt^2`` of its extrapolation at the previous acceleration; when those
    two do not meet (a step already gave up smoothness), the acceleration's alone. Toward the
    speed limit ``vel`` the acceleration must still be able to ramp down to zero at the jerk
    limit before reaching it: ``v' + a'^2 / 2j + a' dt / 2 <= vel`` (the steps of the ramp)."""
    for j in range(qdot_prev.shape[0]):
        a_step, j_step = MOTION_MARGIN * acc[j] * dt_s, MOTION_MARGIN * jerk[j] * dt_s * dt_s
        a_lo, a_hi = qdot_prev[j] - a_step, qdot_prev[j] + a_step
        centre = qdot_prev[j] + qddot_prev[j] * dt_s
        j_lo, j_hi = centre - j_step, centre + j_step
        lo[j], hi[j] = max(a_lo, j_lo), min(a_hi, j_hi)
        if lo[j] > hi[j]:
            lo[j], hi[j] = a_lo, a_hi
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            room = vel[j] - sign * qdot_prev[j]  # speed left before the limit on that side
            if room <= 0.0:
                continue
            a_max = ramp_acceleration(room, jerk[j], dt_s)
            if side == 0:
                hi[j] = max(min(hi[j], qdot_prev[j] + a_max * dt_s), lo[j])
            else:
                lo[j] = min(max(lo[j], qdot_prev[j] - a_max * dt_s), hi[j])


@numba.njit(cache=True)
def within_hand_ball(dv, accel_prev, dt_s, ee_acc, ee_jerk):  # pragma: no cover - compiled
    """Whether the hand's velocity change this step ``dv`` [m/s] (3,) (``J (qdot - qdot_prev)``,
    the part the joints give) keeps its acceleration and jerk limits as the norms they are
    (``EE_MOTION_SHARE`` of ``ee_acc``, ``ee_jerk``, within ``MOTION_MARGIN``; ``accel_prev``
    the previous step's ``J qddot``), and leaves each axis within a jerk step of the per-axis
    box (``EE_AXIS_SHARE``), so that the next step's box (``motion_box``: the acceleration's
    window and the jerk's) still meets. The filter plans the hand within the box inscribed in
    the ball; this is the rest of the ball, taken only where the box alone would make the
    motion limits give way (``step_kernel.arm_step``)."""
    acc2, jerk2 = 0.0, 0.0
    axis = MOTION_MARGIN * EE_AXIS_SHARE * (ee_acc + ee_jerk * dt_s)
    for r in range(3):
        a = dv[r] / dt_s
        if abs(a) > axis:
            return False
        acc2 += a * a
        jerk = (a - accel_prev[r]) / dt_s
        jerk2 += jerk * jerk
    ball_acc, ball_jerk = MOTION_MARGIN * EE_MOTION_SHARE * ee_acc, MOTION_MARGIN * EE_MOTION_SHARE * ee_jerk
    return acc2 <= ball_acc * ball_acc and jerk2 <= ball_jerk * ball_jerk
