"""How fast a limitation may be approached: the speed from which the arm can still stop before it.

``viable_speed`` is the bound the filter uses: from the approach speed *and acceleration* now,
the fastest approach for the next step from which jerk-limited braking still stops before the
limitation (so following it never asks for a jump in acceleration). ``braking_speed`` is the
same for an arm assumed to be accelerating toward the limitation at its limit: a bound on the
speed alone, the fallback when the state is already beyond ``viable_speed``'s reach.

A limitation at gap ``g`` (its distance minus the filter's buffer) [m or rad] may be approached
at speed ``v`` only if braking stops within ``g``. Braking is modelled as a real arm's
controller does it, under an acceleration limit ``a`` and a jerk limit ``j`` along the
limitation's normal, in discrete time steps ``dt``: in the worst case the arm is accelerating
toward the limitation at ``+a`` when it decides to brake, ramps its acceleration down to ``-a``
at the jerk limit (``2 a / j``; its speed rises by ``a^2 / 2j`` and falls back), then brakes at
``-a``. The distance covered is at most::

    D(v) = v^2 / 2a + v (2a / j + dt / 2) + (2/3) a^3 / j^2 + a dt^2

(the ramp's travel, the braking's ``v^2 / 2a``, and the discrete steps' excess: each step holds
its velocity for ``dt``). ``braking_speed`` is the largest ``v`` with ``D(v) <= g``, and at most
``g / dt`` (one step closes at most the gap). This is the viability bound of Del Prete ("Joint
position and velocity bounds in discrete-time acceleration/torque control of robot
manipulators", RA-L 2018), ``qdot >= -sqrt(2 a (q - q_min))`` in its discrete-time form,
extended by the jerk ramp; ``tests/test_arm_braking.py`` simulates the braking from random
states and checks it stops before the limitation.

The same bound serves every limitation: for a joint ``a`` and ``j`` are its own limits times the
braking share; for a Cartesian limitation (zones, table, reach, the human) they are what the
joints can give along its normal ``n`` (``share * sum_i |n_i| a_i``, ramped up at the jerk the
joints keep up from their accelerations now: ``row_capacity``), at most the end-effector's own
limits (per axis: the end-effector's box). For a person walking at the arm
the gap is shortened by how far they walk while the arm's approach ends (``stop_time``, ISO/TS
15066's ``v_h T_s``); ``arm_stop_time`` bounds how long the whole arm takes to stand still.
"""

from __future__ import annotations

import numba
import numpy as np

#: The most ``safe_speed`` scales the motion limits by to stop before a limitation.
MAX_BRAKE_FACTOR = 50.0


@numba.njit(cache=True)
def positive_root(k, lead, room):  # pragma: no cover - compiled
    """The ``x >= 0`` with ``x^2 / 2k + lead x = room`` (``k`` > 0, ``lead`` >= 0; 0 when
    ``room`` <= 0): a speed ``x`` braked at ``k`` after ``lead`` seconds, or an acceleration
    ramped down at jerk ``k``, that covers ``room``. Written ``2 room / (lead + sqrt(lead^2 +
    2 room / k))``, which does not cancel when ``room`` is small (the textbook ``k (sqrt(...) -
    lead)`` loses the digits the subtraction takes). An infinite ``room`` (no limit on that
    side, as the end-effector's speed in its acceleration box) is covered by no finite ``x``:
    ``inf`` (the quotient would be ``inf / inf``, NaN)."""
    if room <= 0.0:
        return 0.0
    if room == np.inf:
        return np.inf
    return 2.0 * room / (lead + np.sqrt(lead * lead + 2.0 * room / k))


@numba.njit(cache=True, inline="always")
def row_capacity(A, i, qdot, qddot, acc, jerk, vel):  # pragma: no cover - compiled
    """Row ``i``'s rate ``a . qdot`` (``a = A[i]``) and what the joints, at ``qdot`` and
    ``qddot`` now under their limits ``vel``, ``acc``, ``jerk``, can do to it, in one pass:
    ``(rate, accel, decel, ramp, ramp_all, reach)``: the rate and its acceleration ``a .
    qddot`` now, the largest acceleration it can take, a jerk at which it can always ramp from
    ``accel`` up to ``decel``, the jerk with every joint ramping (``sum_j |a_j| jerk_j``) and its
    largest speed (``sum_j |a_j| vel_j``).

    Each joint ramps its own acceleration toward its limit on the row's side at its own jerk
    and stops there, so the rate's acceleration rises at ``ramp_all`` only while no joint has
    reached its limit: a joint already at it (the arm braking or turning hard) gives nothing
    more. The sum of those ramps is concave in time, so it stays above the straight line from
    ``accel`` now to ``decel = sum_j |a_j| acc_j`` when the last joint gets there (``T = max_j
    (acc_j - sign(a_j) qddot_j) / jerk_j``): ``ramp`` is that line's slope, at most
    ``ramp_all``. The line is drawn from each joint's acceleration held within its limit (the
    argument holds there): after a step that gave up smoothness a joint beyond its limit would
    otherwise bring ``a . qddot`` up to ``decel`` while another joint still has far to ramp,
    and the slope (``decel - a . qddot`` over that joint's time) collapse: on the iiwa's
    extended reach 0.006 m/s^3 against the hand's 20.8, and the safety bound with it, whose
    next step then asked 51-55 times a joint's acceleration limit (held-out drags)."""
    rate, accel, decel, ramp_all, reach = 0.0, 0.0, 0.0, 0.0, 0.0
    within = 0.0  # the rate's acceleration with each joint's held within its limit
    room_last, jerk_last = 0.0, 1.0  # T = room_last / jerk_last (compared without dividing)
    for j in range(A.shape[1]):
        w = A[i, j]
        rate += w * qdot[j]
        accel += w * qddot[j]
        decel += abs(w) * acc[j]
        ramp_all += abs(w) * jerk[j]
        reach += abs(w) * vel[j]
        if w != 0.0:
            held = min(max(qddot[j], -acc[j]), acc[j])
            within += w * held
            room = acc[j] - (held if w > 0.0 else -held)
            if room * jerk_last > room_last * jerk[j]:
                room_last, jerk_last = room, jerk[j]
    ramp = ramp_all
    if room_last > 0.0 and decel > within:
        ramp = min(ramp_all, (decel - within) * jerk_last / room_last)
    return rate, accel, decel, ramp, ramp_all, reach


@numba.njit(cache=True)
def braking_distance(speed, decel, jerk, dt_s):  # pragma: no cover - compiled
    """``D(v)`` above [m or rad]: the longest braking from ``speed`` >= 0."""
    tau = 2.0 * decel / jerk + 0.5 * dt_s
    return speed * speed / (2.0 * decel) + speed * tau + (2.0 / 3.0) * decel ** 3 / (jerk * jerk) + decel * dt_s * dt_s


@numba.njit(cache=True)
def braking_speed(gap, decel, jerk, dt_s):  # pragma: no cover - compiled
    """The fastest approach [m/s or rad/s] at ``gap`` [m or rad] from which braking at ``decel``
    with jerk ``jerk`` stops before the limitation (``D(v) <= gap``, and ``v <= gap / dt``);
    0 when even that is impossible. ``decel``, ``jerk`` > 0."""
    if gap <= 0.0:
        return 0.0
    tau = 2.0 * decel / jerk + 0.5 * dt_s
    room = gap - (2.0 / 3.0) * decel ** 3 / (jerk * jerk) - decel * dt_s * dt_s
    return min(positive_root(decel, tau, room), gap / dt_s)


@numba.njit(cache=True)
def stop_distance(speed, accel, decel, jerk, dt_s):  # pragma: no cover - compiled
    """How far toward the limitation [m or rad] the arm still goes when it brakes now from
    ``speed`` (toward it: > 0) and acceleration ``accel`` (toward it: > 0): the acceleration
    ramps down to ``-decel`` at ``jerk``, then holds ``-decel`` until the speed is zero.

    Phase 1 (``t <= t1 = (accel + decel) / jerk``): ``v(t) = speed + accel t - jerk t^2 / 2``,
    ``x(t) = speed t + accel t^2 / 2 - jerk t^3 / 6``; the farthest point is where ``v`` turns
    negative (``t+ = (accel + sqrt(accel^2 + 2 jerk speed)) / jerk``) if that is within phase 1,
    else phase 2 adds ``v(t1)^2 / 2 decel``. Plus the discrete steps' excess (each step holds
    its velocity for ``dt``): ``max(speed, 0) dt / 2 + decel dt^2 / 8`` (the sum of a braking
    sequence's steps exceeds the integral by half the first step, plus at most an eighth of a
    step's change at the end)."""
    excess = max(speed, 0.0) * 0.5 * dt_s + 0.125 * decel * dt_s * dt_s
    accel = min(max(accel, -decel), decel)
    t1 = (accel + decel) / jerk
    disc = accel * accel + 2.0 * jerk * speed
    if disc >= 0.0:
        t_turn = (accel + np.sqrt(disc)) / jerk
        if 0.0 <= t_turn <= t1:
            x = speed * t_turn + 0.5 * accel * t_turn * t_turn - jerk * t_turn ** 3 / 6.0
            return max(x, 0.0) + excess
    elif speed <= 0.0:
        return excess  # moving away and never turning back within the ramp
    v1 = speed + accel * t1 - 0.5 * jerk * t1 * t1
    x1 = speed * t1 + 0.5 * accel * t1 * t1 - jerk * t1 ** 3 / 6.0
    if v1 <= 0.0:
        return max(x1, 0.0) + excess
    return max(x1 + v1 * v1 / (2.0 * decel), 0.0) + excess


@numba.njit(cache=True)
def stop_time(speed, accel, decel, jerk, dt_s):  # pragma: no cover - compiled
    """An upper bound [s] on how long the arm takes to stand still along a limitation's normal
    when it brakes now from ``speed`` and acceleration ``accel`` (toward it: > 0), as in
    ``stop_distance``: the ramp to ``-decel`` (``(accel + decel) / jerk``), then the speed left
    (at most ``speed + accel^2 / 2 jerk``) at ``decel``, plus two steps (each phase rounded up
    to whole steps)."""
    accel = min(max(accel, -decel), decel)
    peak = max(speed, 0.0) + 0.5 * max(accel, 0.0) ** 2 / jerk
    return (accel + decel) / jerk + peak / decel + 2.0 * dt_s


@numba.njit(cache=True)
def arm_stop_time(qdot, qddot, ee_velocity, acc, jerk, ee_axis_acc, ee_axis_jerk, dt_s):  # pragma: no cover - compiled
    """An upper bound [s] on how long the whole arm takes to stand still if it starts braking
    after one more step at its limits: every joint (speed ``|qdot|`` plus one step of ``acc``,
    its acceleration toward speeding up) and the hand's fastest axis (``ee_velocity``, within
    its per-axis box ``ee_axis_acc``, ``ee_axis_jerk``), each by ``stop_time``; the longest."""
    longest = 0.0
    for j in range(qdot.shape[0]):
        speed = abs(qdot[j])
        speeding = qddot[j] if qdot[j] >= 0.0 else -qddot[j]
        longest = max(longest, stop_time(speed + acc[j] * dt_s, speeding, acc[j], jerk[j], dt_s))
    hand = 0.0
    for r in range(ee_velocity.shape[0]):
        hand = max(hand, abs(ee_velocity[r]))
    return max(longest, stop_time(hand + ee_axis_acc * dt_s, ee_axis_acc, ee_axis_acc, ee_axis_jerk, dt_s))


@numba.njit(cache=True, inline="always")
def hardest_braking(speed, accel, decel, jerk, dt_s):  # pragma: no cover - compiled
    """``(lo, s_lo)``: the hardest braking the limits allow now (``accel - jerk dt``, at least
    ``-decel``) and the next step's approach speed under it."""
    lo = max(accel - jerk * dt_s, -decel)
    return lo, speed + lo * dt_s


@numba.njit(cache=True)
def hardest_braking_excess(gap, speed, accel, decel, jerk, dt_s):  # pragma: no cover - compiled
    """``(s_lo, f)``: the next step's approach speed under ``hardest_braking``, and how far
    beyond ``gap`` its stop still goes (``f > 0``: not viable, whatever the next step does)."""
    lo, s_lo = hardest_braking(speed, accel, decel, jerk, dt_s)
    return s_lo, stop_distance(s_lo, lo, decel, jerk, dt_s) + s_lo * dt_s - gap


@numba.njit(cache=True)
def viable_speed(gap, speed, accel, decel, jerk, dt_s, speed_cap):  # pragma: no cover - compiled
    """The fastest approach [m/s or rad/s] for the next step from which the arm can still brake
    before the limitation, given its approach ``speed`` and acceleration ``accel`` now and its
    limits along the normal (``decel``, ``jerk``): the largest ``s'`` with
    ``stop_distance(s', a') <= gap - s' dt``, ``a' = (s' - speed) / dt`` (within ``+-decel``).
    It bounds viability only (how fast the arm may reach is the motion limits' business):
    ``inf`` when even ``speed_cap`` is viable. Enforced at every step, it never asks the arm
    for more than ``decel`` and ``jerk``: the hardest braking allowed now (``accel - jerk dt``)
    keeps the state viable, and braking from it needs no more. NaN when even that is not enough
    (a human appearing closer than the arm can brake for, a start inside a limitation): the
    caller falls back to ``braking_speed`` and smoothness gives way."""
    if gap <= 0.0:
        return np.nan
    # Far from the limitation (most rows, most steps): the longest braking from the fastest
    # speed in question, ``D`` above, already fits, so ``f`` below is <= 0 there: ``inf``
    # without the search (``D`` exceeds every ``stop_distance`` by at least 7/8 decel dt^2).
    s_far = max(speed_cap, hardest_braking(speed, accel, decel, jerk, dt_s)[1])
    if braking_distance(s_far, decel, jerk, dt_s) + s_far * dt_s <= gap:
        return np.inf
    s_lo, f_lo = hardest_braking_excess(gap, speed, accel, decel, jerk, dt_s)
    if f_lo > 0.0:
        return np.nan
    s_hi = max(speed_cap, s_lo)
    # From ``s_full`` on the step accelerates at the full ``decel`` (a' clipped): there the stop
    # ramps from +decel to -decel (``t1 = 2 decel / jerk``), leaves the ramp at ``s'`` itself
    # and brakes at -decel, so ``f`` is a quadratic in ``s'``:
    # ``s'^2 / 2 decel + s' (t1 + 1.5 dt) + (2/3) decel^3 / jerk^2 + decel dt^2 / 8 - gap``.
    # Its root, when it lies in that regime, is the answer; else the search below.
    s_full = speed + decel * dt_s
    room = gap - (2.0 / 3.0) * decel ** 3 / (jerk * jerk) - 0.125 * decel * dt_s * dt_s
    if room > 0.0:
        root = positive_root(decel, 2.0 * decel / jerk + 1.5 * dt_s, room)
        if root >= s_full and root > 0.0:
            return np.inf if root >= s_hi else root
    a_hi = min(max((s_hi - speed) / dt_s, -decel), decel)
    f_hi = stop_distance(s_hi, a_hi, decel, jerk, dt_s) + s_hi * dt_s - gap
    if f_hi <= 0.0:
        return np.inf
    # f(s) = stop_distance(s, a(s)) + s dt - gap increases with s: its root by regula falsi
    # (Illinois), the bracket's feasible end returned.
    side = 0
    for _ in range(60):
        s_mid = s_lo - f_lo * (s_hi - s_lo) / (f_hi - f_lo)
        if not s_lo < s_mid < s_hi:
            s_mid = 0.5 * (s_lo + s_hi)
        a_mid = min(max((s_mid - speed) / dt_s, -decel), decel)
        f_mid = stop_distance(s_mid, a_mid, decel, jerk, dt_s) + s_mid * dt_s - gap
        if f_mid <= 0.0:
            s_lo, f_lo = s_mid, f_mid
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            s_hi, f_hi = s_mid, f_mid
            if side == 1:
                f_lo *= 0.5
            side = 1
        if s_hi - s_lo <= 1e-12 * max(1.0, abs(s_lo)) or f_lo == 0.0:
            break
    return s_lo


@numba.njit(cache=True, inline="always")
def beyond_ramp(A, i, qddot, acc, jerk, capacity, accel):  # pragma: no cover - compiled
    """Row ``i``'s jerk when its joints' limits are scaled by ``f >= 1`` (``safe_speed`` beyond the
    limits), as ``(slope, start)``: at least ``f slope - start``. Each joint then ramps toward
    ``f acc_j`` at ``f jerk_j`` and gets there within ``T = max_j max(2 acc_j, acc_j + |qddot_j|)
    / jerk_j`` whatever ``f``; the rate's acceleration, concave in time, stays above the chord from
    ``accel = a . qddot`` now to ``f capacity`` (``capacity = sum_j |a_j| acc_j``; both as
    ``row_capacity`` returns them) at ``T``: ``slope = capacity / T``, ``start = accel / T``.
    Unlike ``row_capacity``'s ramp scaled by ``f`` (the chord within the limits), it does not
    vanish when the row already brakes at its capacity."""
    t_max = 0.0
    for j in range(A.shape[1]):
        if A[i, j] != 0.0:
            t_max = max(t_max, max(2.0 * acc[j], acc[j] + abs(qddot[j])) / jerk[j])
    if t_max <= 0.0:
        return 0.0, 0.0
    return capacity / t_max, accel / t_max


@numba.njit(cache=True, inline="always")
def _jerk_at(factor, jerk, jerk_all, slope, start):  # pragma: no cover - compiled
    """The jerk at ``factor`` times the limits: ``factor jerk``, or ``beyond_ramp``'s chord (at
    most every joint's ``factor jerk_all``) when that is steeper."""
    return max(factor * jerk, min(factor * jerk_all, factor * slope - start))


@numba.njit(cache=True)
def safe_speed(gap, speed, accel, decel, jerk, dt_s, speed_cap, jerk_all=0.0, slope=0.0,
               start=0.0):  # pragma: no cover - compiled
    """``viable_speed``, and when the state is beyond its reach, the same bound with the
    deceleration and jerk scaled up by the least factor that makes it viable again (by
    bisection below ``MAX_BRAKE_FACTOR``): safety wins over smoothness, exceeding the motion
    limits only as much as stopping before the limitation needs. At a factor ``f`` the jerk is
    ``f jerk``; when that is not viable even at ``MAX_BRAKE_FACTOR``, the search is made again
    with, where steeper, the row's chord at the scaled limits (``beyond_ramp``'s ``f slope -
    start``, at most ``f jerk_all``) before falling back: ``jerk``, a chord to the capacity within
    the limits, nearly vanishes for a row already braking at that capacity, and scaled it found no
    viable factor up to 50 where 1.8 was (a held-out drag's fallback to approach nothing asked
    18.8, then 595 times a joint's limit). (Taken at every factor, the steeper chord let the arm
    ride closer to the edge: a counted step in exp1 at 1 kHz.) Without them (the defaults) the
    jerk scales with the factor. Returns ``(speed [m/s or
    rad/s], factor)`` (factor 1: within the limits); at a gap <= 0, ``(0, 1)``; when the
    braking is not viable at ``MAX_BRAKE_FACTOR``, ``braking_speed`` at that factor (the step
    may then close the gap at once). The hardest braking's excess is not monotone in the factor
    (it falls as the limits grow, then rises with the discrete steps' excess), so that fallback
    can come where a smaller factor would do: found, measured and kept (searching for the least
    factor made the iiwa's drags worse: docs/motion_limits.md, "Held-out drag seeds")."""
    allowed = viable_speed(gap, speed, accel, decel, jerk, dt_s, speed_cap)
    if not np.isnan(allowed):
        return allowed, 1.0
    if gap <= 0.0:
        return 0.0, 1.0
    lo, hi = 1.0, MAX_BRAKE_FACTOR
    # (viable at a factor: the hardest braking then stops before the limitation; the bound
    # itself is computed once, at the factor found)
    if hardest_braking_excess(gap, speed, accel, hi * decel, hi * jerk, dt_s)[1] > 0.0:
        # Not viable even at ``MAX_BRAKE_FACTOR`` with the jerk scaled: the joints' chord at the
        # scaled limits (``beyond_ramp``), before falling back to approach nothing.
        top = _jerk_at(hi, jerk, jerk_all, slope, start)
        if top == hi * jerk or hardest_braking_excess(gap, speed, accel, hi * decel, top, dt_s)[1] > 0.0:
            return braking_speed(gap, hi * decel, top, dt_s), hi
    else:
        jerk_all, slope, start = 0.0, 0.0, 0.0  # (``_jerk_at`` is then ``factor * jerk``)
    for _ in range(30):
        mid = np.sqrt(lo * hi)
        if hardest_braking_excess(gap, speed, accel, mid * decel, _jerk_at(mid, jerk, jerk_all, slope, start),
                                  dt_s)[1] > 0.0:
            lo = mid
        else:
            hi = mid
    return viable_speed(gap, speed, accel, hi * decel, _jerk_at(hi, jerk, jerk_all, slope, start), dt_s,
                        speed_cap), hi
