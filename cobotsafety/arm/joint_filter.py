"""The anticipative filter in joint space: the joint velocity closest to the user's command that
keeps every limitation, the robot's speed limits, and (when it can) its acceleration and jerk.

Decision variable: the joint velocity ``qdot`` (nv,), written ``qdot = q0 + B z``: ``q0`` is the
command's own joint-space solution (``task.task_mapping``: ``M v + c``) and ``B = [M | Z / eps]``
maps ``z = (u - v, eps w)`` to joint velocities, ``u`` the hand's command and ``w`` the body's
motion in the null space of the hand (``task.null_basis``). Minimising ``||z||`` is the least
squares in the task space with a small regularisation of the body's motion::

    min ||u - v||^2 + eps^2 ||w||^2

so when nothing binds ``qdot = M v + c`` exactly, and when a limitation on the body binds, the
arm moves its body (cheap: ``eps`` [m/rad] weighs 1 rad/s of posture change as ``eps`` m/s of
hand deviation) before it slides the hand. ``B = I`` and ``q0`` a joint velocity give the
plain projection of that velocity (paper 2's field, sliding off the limitations).

Every row is a half-space ``a . qdot >= b`` (``tests/test_arm_joint_filter.py`` holds the
result equal to quadprog's on random problems), in six groups by priority:

* ``LIMITATION``: each limitation's *safety* bound, the approach from which the arm can still
  brake before it with its full motion limits (``braking.safe_speed``), and the robot's own
  end-effector speed limit: hard;
* ``RECOVERY``: the safety bound of a limitation the arm is already inside (its buffer) with
  nothing walking at it (``step_kernel``: a person standing), drifting out at the recovery
  gain: hard down to "approach nothing";
  its retreat gives way (to what it can grow to in a step, then to that) before the motion
  limits do (a retreat is not a stop);
* ``VELOCITY``: each joint's speed limit: hard;
* ``MOTION``: each joint's acceleration and jerk limits, as the box of velocities the next step
  may take from the previous one;
* ``HAND``: the end-effector's acceleration and jerk limits, the same box for the hand; when the
  hard rows contradict the motion rows these give way first, the joints' only if that is not
  enough: the joints' limits are the ones a robot's controller enforces on a joint command
  (libfranka's joint reflexes, KUKA's), the hand's are a Cartesian interface's (libfranka) or
  our principle (the iiwa's 0.2 g);
* ``PLAN``: each limitation's *planning* bound, the same with a share of the motion limits
  (``FilterSettings.brake_share``): the arm plans to brake gently, and has the rest in reserve;
  and the command's speed cap, on the velocity the hand reaches once its acceleration has
  ramped down (``filter_rows``). The end-effector's speeds are norms (``||J qdot|| <= cap``),
  met by adding the ball's tangent plane at the solution as a row, at most ``SPEED_CUTS``
  times.

Priorities, from the strictest: the hard rows always; then the motion rows (the plan's margin
gives way first, by least squares, ``least_distance.relax_kernel``); then, only when the hard
rows need it, the motion rows too (safety wins over smoothness: each such step is counted) —
but when the hard rows agree, the recoveries' retreats give way first, down to "approach
nothing", and the motion limits then only as far as going no deeper needs;
when the hard rows contradict each other, the limitations' retreats (bounds > 0: a human
closing in, a limit already inside its buffer) give way too, each down to "approach nothing";
when that fails, every limitation is held at "approach nothing"; when that fails too, the arm
is stopped (zero joint velocity).
"""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.least_distance import RELAX_DONE, RELAXATION_COMMAND_WEIGHT, relax_kernel
from cobotsafety.small_linalg import matvec

LIMITATION, VELOCITY, MOTION, PLAN, RECOVERY, HAND = 0, 1, 2, 3, 4, 5
#: How the filter ended: within the motion limits; motion limits given up for safety; retreats
#: relaxed; approaching nothing; stopped.
LEVEL_EXACT, LEVEL_SMOOTHNESS, LEVEL_RELAXED, LEVEL_APPROACH_NOTHING, LEVEL_STOPPED = 0, 1, 2, 3, 4
#: The most tangent planes the end-effector's speed cap may add.
SPEED_CUTS = 8
#: A row counts as binding when the command is within this of its bound (same unit as ``b``).
BINDING_TOLERANCE = 1e-9


@numba.njit(cache=True, inline="always")
def is_motion(group):  # pragma: no cover - compiled
    """A motion row: the joints' (``MOTION``) or the hand's (``HAND``) acceleration and jerk box."""
    return group == MOTION or group == HAND


@numba.njit(cache=True)
def _relax(q0, B, G, h, soft, floors):  # pragma: no cover - compiled
    """``relax_kernel`` on the z-space rows: ``(qdot, violation, done)``."""
    z, violation, status, _, _ = relax_kernel(np.zeros(G.shape[1]), G, h, soft, floors, RELAXATION_COMMAND_WEIGHT)
    return q0 + matvec(B, z), violation, status == RELAX_DONE


@numba.njit(cache=True)
def _relax_lowered(q0, B, G, h, lowered, soft, floors):  # pragma: no cover - compiled
    """``_relax`` with some rows' bounds given way to ``lowered`` (below ``h``): each row's
    violation counts from its full bound ``h``."""
    qdot, violation, done = _relax(q0, B, G, lowered, soft, floors)
    if done:
        for i in range(h.shape[0]):
            violation[i] += h[i] - lowered[i]
    return qdot, violation, done


@numba.njit(cache=True)
def _solve(q0, B, N, b, ramp, group, count, first_level):  # pragma: no cover - compiled
    """One solve of the rows ``[:count]`` at the priorities above, from level ``first_level``
    on (the cut loop keeps a level once reached): ``(qdot, violation (count,), level)``.
    ``ramp``: the bound each ``RECOVERY`` row gives way to first (what its retreat can grow to
    this step), then to approach nothing."""
    nv, nz = B.shape
    G = np.zeros((count, nz))
    h = np.empty(count)
    base = np.empty(count)  # a . q0
    for i in range(count):
        s = 0.0
        for k in range(nv):
            s += N[i, k] * q0[k]
        base[i] = s
        for j in range(nz):
            t = 0.0
            for k in range(nv):
                t += N[i, k] * B[k, j]
            G[i, j] = t
        h[i] = b[i] - s
    soft = np.zeros(count, dtype=np.bool_)
    floors = np.full(count, -np.inf)
    eased = h.copy()  # the recoveries at "approach nothing" (a . qdot >= 0)
    recovering = False
    for i in range(count):
        soft[i] = group[i] == PLAN
        if group[i] == RECOVERY and b[i] > 0.0:
            eased[i] = -base[i]
            recovering = True
    if first_level <= LEVEL_EXACT:
        qdot, violation, done = _relax(q0, B, G, h, soft, floors)
        if done:
            return qdot, violation, LEVEL_EXACT
    if first_level <= LEVEL_SMOOTHNESS and not recovering:
        # The hand's limits give way first (by least squares, with the plan's margin), the
        # joints' kept.
        for i in range(count):
            soft[i] = group[i] == PLAN or group[i] == HAND
        qdot, violation, done = _relax(q0, B, G, h, soft, floors)
        if done:
            return qdot, violation, LEVEL_SMOOTHNESS
    for i in range(count):
        soft[i] = group[i] == PLAN or is_motion(group[i])
    if first_level <= LEVEL_SMOOTHNESS:
        qdot, violation, done = _relax(q0, B, G, h, soft, floors)
        if done and recovering:
            # The retreats agree once the motion limits give way: the recoveries' give way
            # instead, the motion limits kept, to what their retreat can grow to this step
            # (``ramp``), then to approach nothing (asked again in full next step); when that
            # is not enough the motion limits give way only for approaching nothing. (Not by
            # least squares: the arm would spin its body at the joints' speed limits for
            # micrometres of retreat.)
            if first_level <= LEVEL_EXACT:
                for i in range(count):
                    soft[i] = group[i] == PLAN
                ramped = eased.copy()
                ramping = False
                for i in range(count):
                    if eased[i] != h[i] and ramp[i] > 0.0:
                        ramped[i] = min(ramp[i], b[i]) - base[i]
                        ramping = True
                if ramping:
                    eased_qdot, eased_violation, eased_done = _relax_lowered(q0, B, G, h, ramped, soft, floors)
                    if eased_done:
                        return eased_qdot, eased_violation, LEVEL_EXACT
                eased_qdot, eased_violation, eased_done = _relax_lowered(q0, B, G, h, eased, soft, floors)
                if eased_done:
                    return eased_qdot, eased_violation, LEVEL_EXACT
                for i in range(count):
                    soft[i] = group[i] == PLAN or is_motion(group[i])
            eased_qdot, eased_violation, eased_done = _relax_lowered(q0, B, G, h, eased, soft, floors)
            if eased_done:
                return eased_qdot, eased_violation, LEVEL_SMOOTHNESS
        if done:
            return qdot, violation, LEVEL_SMOOTHNESS
    if first_level <= LEVEL_RELAXED:
        relaxable = soft.copy()
        any_retreat = False
        for i in range(count):
            if (group[i] == LIMITATION or group[i] == RECOVERY) and b[i] > 0.0:
                relaxable[i] = True
                floors[i] = -base[i]  # a . qdot >= 0: approach nothing
                any_retreat = True
        if any_retreat:
            qdot, violation, done = _relax(q0, B, G, h, relaxable, floors)
            if done:
                return qdot, violation, LEVEL_RELAXED
        for i in range(count):
            floors[i] = -np.inf
    lowered = h.copy()
    for i in range(count):
        if (group[i] == LIMITATION or group[i] == RECOVERY or group[i] == PLAN) and b[i] > 0.0:
            lowered[i] = -base[i]
    qdot, violation, done = _relax_lowered(q0, B, G, h, lowered, soft, floors)
    if done:
        return qdot, violation, LEVEL_APPROACH_NOTHING
    return np.zeros(nv), np.zeros(count), LEVEL_STOPPED


@numba.njit(cache=True)
def filter_rows(q0, B, N, b, ramp, group, count, J, speed_cap, speed_limit, ee_prev, lead, ahead_cap):  # pragma: no cover - compiled
    """The filtered joint velocity for the rows ``N[:count] @ qdot >= b[:count]`` (groups
    ``group``), ``qdot = q0 + B z``, and the end-effector's speed: ``||J qdot|| <= speed_limit``
    (the robot's: hard), ``<= speed_cap`` (the command's cap this step: planned, a ``PLAN``
    row), and the command's cap ``ahead_cap`` (planned) on the velocity the hand reaches once
    its acceleration has ramped down to zero::

        ||u + lead * (u - ee_prev)|| <= ahead_cap,   u = J qdot

    ``ee_prev`` (3,): the hand's previous velocity seen through ``J``; ``lead`` (3,) per axis,
    ``|a| / (2 j dt) + 1`` from the hand's previous acceleration ``a`` and its jerk limit ``j``:
    an axis accelerating at ``a'`` gains ``a' |a'| / 2j + a' dt / 2`` while its acceleration
    ramps down in steps of ``dt`` (``motion_box.ramp_acceleration``'s ramp), at most
    ``lead a' dt`` since ``|a'| <= |a| + j dt``. So the hand turning at the cap does not build an
    acceleration it can only shed beyond it (the xArm 7's 50 m/s^2 and 100 m/s^3 took a turning
    hand from the 0.5 m/s cap to its own 1 m/s limit). ``lead`` 0: the plain cap.

    ``ramp``: for a ``RECOVERY`` row, the retreat it gives way to first (> 0; else straight to
    approach nothing). ``N``, ``b``, ``ramp``, ``group`` have room for ``SPEED_CUTS`` more rows
    after ``count``. Returns
    ``(qdot (nv,), violation (rows,), level, rows)``: how much each row's bound was given up
    (motion rows: smoothness given up for safety; limitation rows: retreats relaxed), the
    level reached (``LEVEL_*``) and the rows used (``count`` plus the speed cuts)."""
    qdot, violation, level = _solve(q0, B, N, b, ramp, group, count, LEVEL_EXACT)
    rows = count
    for _ in range(SPEED_CUTS):
        if level == LEVEL_STOPPED:
            break
        ee = matvec(J, qdot)
        speed = np.sqrt(np.sum(ee * ee))
        ahead = ee + lead * (ee - ee_prev)
        ahead_speed = np.sqrt(np.sum(ahead * ahead))
        # The tangent plane at the solution of the ball it leaves, ``w . (J qdot) <= b``: the
        # robot's limit or this step's cap (``w = e = J qdot / |J qdot|``), else the cap ahead
        # (``w = e (1 + lead)``, ``e`` the unit ``ahead``, its bound raised by ``e . lead ee_prev``).
        if speed > speed_cap * (1.0 + 1e-9):
            hard = speed > speed_limit * (1.0 + 1e-9)
            w = ee / speed
            b[rows] = -(speed_limit if hard else speed_cap)
            group[rows] = LIMITATION if hard else PLAN
        elif ahead_speed > ahead_cap * (1.0 + 1e-9):
            e = ahead / ahead_speed
            w = e * (1.0 + lead)
            b[rows] = -(ahead_cap + e[0] * lead[0] * ee_prev[0] + e[1] * lead[1] * ee_prev[1]
                        + e[2] * lead[2] * ee_prev[2])
            group[rows] = PLAN
        else:
            break
        for k in range(N.shape[1]):
            N[rows, k] = -(w[0] * J[0, k] + w[1] * J[1, k] + w[2] * J[2, k])
        rows += 1
        qdot, violation, level = _solve(q0, B, N, b, ramp, group, rows, level)
    return qdot, violation, level, rows
