"""The joints' motion box (``motion_box.motion_box``) against its definition. The hand's ball
(``motion_box.within_hand_ball``): the rest of the hand's acceleration and jerk limits beyond the
per-axis box the filter plans with, against its definition written from the norms and from the
next step's box (its two velocity windows meet)."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cobotsafety.arm.motion_box import EE_AXIS_SHARE, EE_MOTION_SHARE, MOTION_MARGIN, motion_box, within_hand_ball


def next_box_meets(v, v_next, a_next, box_acc, box_jerk, dt):
    """The next step's per-axis windows (``motion_box``, in velocities): within ``box_acc dt`` of
    ``v_next`` and within ``box_jerk dt^2`` of its extrapolation at ``a_next``."""
    lo = np.maximum(v_next - box_acc * dt, v_next + a_next * dt - box_jerk * dt * dt)
    hi = np.minimum(v_next + box_acc * dt, v_next + a_next * dt + box_jerk * dt * dt)
    return bool(np.all(lo <= hi + 1e-15 * (1.0 + np.abs(v))))


def test_within_hand_ball_is_the_ball_and_the_next_box():
    rng = np.random.default_rng(20261206)
    checked = {True: 0, False: 0}
    for robot_acc, robot_jerk in ((13.0, 6500.0), (2.0, 40.0), (0.64, 12.8)):
        ball_acc, ball_jerk = MOTION_MARGIN * EE_MOTION_SHARE * robot_acc, MOTION_MARGIN * EE_MOTION_SHARE * robot_jerk
        box_acc, box_jerk = MOTION_MARGIN * EE_AXIS_SHARE * robot_acc, MOTION_MARGIN * EE_AXIS_SHARE * robot_jerk
        for dt in (0.001, 1 / 275):
            for _ in range(3000):
                v = rng.normal(size=3) * 0.3
                a_prev = rng.normal(size=3) * box_acc * rng.uniform(0.0, 1.0)
                # accelerations near the box's faces, the ball and the jerk's ball around a_prev
                a = a_prev + rng.normal(size=3) * ball_jerk * dt * rng.uniform(0.2, 1.5)
                if rng.uniform() < 0.5:
                    a = rng.normal(size=3)
                    a *= ball_acc * rng.uniform(0.6, 1.2) / np.linalg.norm(a)
                dv = a * dt
                expected = (np.linalg.norm(a) <= ball_acc and np.linalg.norm((a - a_prev) / dt) <= ball_jerk
                            and next_box_meets(v, v + dv, a, box_acc, box_jerk, dt))
                assert within_hand_ball(dv, a_prev, dt, robot_acc, robot_jerk) == expected, (robot_acc, dt, a, a_prev)
                checked[expected] += 1
    assert min(checked.values()) > 1000  # both answers exercised


def ramp_peak(v_next, a_next, jerk, dt):
    """The highest velocity reached after a step to ``v_next`` at acceleration ``a_next`` > 0
    when every following step lowers the acceleration by the jerk limit (``jerk dt``) until it
    is no longer positive: the discrete ramp down the box must leave room for."""
    v, a, peak = v_next, a_next, v_next
    while True:
        a -= jerk * dt
        if a <= 0.0:
            return peak
        v += a * dt
        peak = max(peak, v)


@settings(max_examples=300, deadline=None)
@given(v_prev=st.floats(-0.999, 0.999), a_share=st.floats(-3.0, 3.0), acc=st.floats(0.5, 50.0),
       jerk_exp=st.floats(1.0, 4.0), vel=st.floats(0.1, 3.0), dt=st.sampled_from((1e-3, 1 / 275, 4e-3, 1e-2)))
def test_the_motion_box_keeps_acceleration_jerk_and_room_to_ramp_down_before_the_speed_limit(
        v_prev, a_share, acc, jerk_exp, vel, dt):
    """Every velocity of the box is within ``acc dt`` of the previous one; within ``jerk dt^2``
    of its extrapolation at the previous acceleration when that window meets the first (else the
    acceleration's window alone: a step gave smoothness up, the next one may not jump further);
    and from either end, ramping the acceleration down at the jerk limit step by step never
    passes the speed limit (from a state that could ramp down itself: the box keeps it so)."""
    jerk = 10.0 ** jerk_exp
    v0, a0 = v_prev * vel, a_share * acc
    assume(ramp_peak(v0, a0, jerk, dt) <= vel if a0 > 0.0 else -ramp_peak(-v0, -a0, jerk, dt) >= -vel)
    lo, hi = np.empty(1), np.empty(1)
    motion_box(np.array([v0]), np.array([a0]), np.array([acc]), np.array([jerk]), np.array([vel]), dt, lo, hi)
    lo, hi = float(lo[0]), float(hi[0])
    tol = 1e-12 * max(1.0, vel)
    assert lo <= hi
    a_step, j_step = MOTION_MARGIN * acc * dt, MOTION_MARGIN * jerk * dt * dt
    for v in (lo, hi, 0.5 * (lo + hi)):
        assert abs(v - v0) <= a_step + tol
        windows_meet = max(v0 - a_step, v0 + a0 * dt - j_step) <= min(v0 + a_step, v0 + a0 * dt + j_step)
        if windows_meet:
            assert abs(v - (v0 + a0 * dt)) <= j_step + tol
        a_next = (v - v0) / dt
        if a_next > 0.0:
            assert ramp_peak(v, a_next, jerk, dt) <= vel + tol
        elif a_next < 0.0:
            assert -ramp_peak(-v, -a_next, jerk, dt) >= -vel - tol
