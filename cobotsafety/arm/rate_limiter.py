"""What a real arm's motion generator makes of a joint-velocity command: its rate limiter.

The filter's command keeps the robot's motion limits except in its counted safety-over-
smoothness steps (``StepReport.safety_over_smoothness``): there it asks for more acceleration
than the arm has. A real arm does not follow such a command. Franka's FCI client offers a rate
limiter for joint-velocity commands (libfranka's ``franka::limitRate`` in ``rate_limiting.cpp``,
the ``limit_rate`` option of ``Robot::control``); without it the arm stops with a reflex. This
module is that limiter's rule, applied per joint (``limit_rate``), as a model of the **plant**:
the arm the filter drives, not part of the filter (issue 20 item 3 keeps the filter's own
limits inside its projection). Per joint, from the last commanded velocity ``v`` and
acceleration ``a``, over the period ``dt``::

    jerk = ((v_c - v) / dt - a) / dt                      clipped to +-J
    a'   = a + jerk dt                                      clipped to [lo(v), hi(v)]
    v'   = v + a' dt
    hi(v) = min(g (V - v), A),  lo(v) = max(g (-V - v), -A),  g = min(J / A, 1 / dt)

with the robot's velocity ``V``, acceleration ``A`` and jerk ``J`` limits (``MotionLimits``):
the acceleration allowed shrinks as the speed nears its limit, so the speed meets it at the
jerk allowed. libfranka's gain is ``J / A`` at its fixed 1 ms; ``g`` caps it at ``1 / dt`` so
that a longer period (the campaign's 275 Hz: the Panda's ``J / A`` is 500 /s, 1.8 / dt) cannot
carry the speed past ``V`` (``v' <= V`` follows from ``a' <= (V - v) / dt``). A joint whose jerk
and acceleration are inside their clips keeps its commanded velocity exactly (not re-summed).

``follow_rate_limited(arm, ...)`` closes the loop: after a step it passes the step's joint
velocity through the limiter and, where it changed (by more than rounding, ``ROUNDING_RAD_S``),
puts the arm at the state the limited motion reaches (``ArmController.set_measured_state``), so
the next step starts from what the arm did.
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.arm.motion_box import ROUNDING_RAD_S
from cobotsafety.arm.motion_limits import MotionLimits

# A change by the limiter no larger than ``ROUNDING_RAD_S`` is rounding, taken as none: the
# filter meets its bounds to that (``step_kernel``), and a joint held at its speed limit was
# commanded 1e-14 rad/s beyond it (campaign person 21, panda: 5 steps "changed" by that; 115 of
# the panda's 1,000 people at aa6cf1f).


@numba.njit(cache=True)
def limit_rate_kernel(qdot_commanded, qdot_last, qddot_last, v_max, a_max, j_max, dt_s, out):  # pragma: no cover - compiled
    """``limit_rate``'s rule joint by joint into ``out`` (nv,); returns the largest change
    ``|out - qdot_commanded|`` [rad/s]."""
    change = 0.0
    for i in range(qdot_commanded.shape[0]):
        jerk = ((qdot_commanded[i] - qdot_last[i]) / dt_s - qddot_last[i]) / dt_s
        clipped_jerk = min(max(jerk, -j_max[i]), j_max[i])
        a = qddot_last[i] + clipped_jerk * dt_s
        gain = min(j_max[i] / a_max[i], 1.0 / dt_s)
        hi = min(gain * (v_max[i] - qdot_last[i]), a_max[i])
        lo = max(gain * (-v_max[i] - qdot_last[i]), -a_max[i])
        limited_a = min(max(a, lo), hi)
        if clipped_jerk == jerk and limited_a == a:
            out[i] = qdot_commanded[i]
        else:
            out[i] = qdot_last[i] + limited_a * dt_s
        change = max(change, abs(out[i] - qdot_commanded[i]))
    return change


def limit_rate(limits: MotionLimits, qdot_commanded: np.ndarray, qdot_last: np.ndarray, qddot_last: np.ndarray,
               dt_s: float) -> np.ndarray:
    """The joint velocity (nv,) [rad/s] the rate limiter lets through after ``qdot_last`` (nv,)
    [rad/s] and ``qddot_last`` (nv,) [rad/s²] over ``dt_s`` [s] (module docstring)."""
    nv = len(limits.velocity_rad_s)
    arrays = [np.asarray(x, dtype=float) for x in (qdot_commanded, qdot_last, qddot_last)]
    for name, array in zip(("qdot_commanded", "qdot_last", "qddot_last"), arrays):
        if array.shape != (nv,):  # (the compiled rule reads nv entries of each)
            raise ValueError(f"limit_rate: {name} must have shape ({nv},), got {array.shape}")
    out = np.empty(nv)
    limit_rate_kernel(*arrays, limits.velocity_rad_s, limits.acceleration_rad_s2, limits.jerk_rad_s3, float(dt_s), out)
    return out


def follow_rate_limited(arm, q_before: np.ndarray, qdot_last: np.ndarray, qddot_last: np.ndarray,
                        dt_s: float) -> bool:
    """After ``arm`` (``ArmController``) stepped from ``q_before`` (nq,) with the last velocity
    ``qdot_last`` and acceleration ``qddot_last`` (nv,): the arm follows its step's joint
    velocity through ``limit_rate``; returns whether the limiter changed it by more than
    rounding (then the arm is put at the state the limited motion reaches)."""
    limits = arm.model.limits
    limited = np.empty(len(qdot_last))
    change = limit_rate_kernel(arm.joint_velocity_rad_s, qdot_last, qddot_last, limits.velocity_rad_s,
                               limits.acceleration_rad_s2, limits.jerk_rad_s3, dt_s, limited)
    if change <= ROUNDING_RAD_S:
        return False
    q = arm.model.integrate(q_before, limited * dt_s)
    arm.set_measured_state(q, limited, (limited - qdot_last) / dt_s)
    return True
