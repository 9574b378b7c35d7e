"""The hand's ball (``motion_box.within_hand_ball``): the rest of the hand's acceleration and jerk
limits beyond the per-axis box the filter plans with, against its definition written from the
norms and from the next step's box (its two velocity windows meet)."""

from __future__ import annotations

import numpy as np

from cobotsafety.arm.motion_box import EE_AXIS_SHARE, EE_MOTION_SHARE, MOTION_MARGIN, within_hand_ball


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
