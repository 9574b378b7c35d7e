"""ISO/TS 15066 SSM (``control/ssm.py``): S by hand and against a root finder, the protective stop
at S, speed scaling as S's inverse, the braking deceleration a robot's joint limits allow."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import brentq

from cobotsafety.arm.ssm import (SsmParams, braking_deceleration_m_s2, max_approach_speed_m_s,
                                     protective_separation_m, protective_stop, stopping_distance_m,
                                     stopping_time_s)


def test_protective_separation_matches_a_hand_computation():
    p = SsmParams(human_speed_m_s=1.6, reaction_time_s=0.1, braking_m_s2=2.0, intrusion_m=0.0,
                  sensor_uncertainty_m=0.05, robot_uncertainty_m=0.01)
    # v_r 0.5 m/s: T_s = 0.25 s, B = 0.0625 m; S = 1.6 * 0.35 + 0.5 * 0.1 + 0.0625 + 0.06 = 0.7325 m
    assert stopping_time_s(0.5, 2.0) == pytest.approx(0.25)
    assert stopping_distance_m(0.5, 2.0) == pytest.approx(0.0625)
    assert protective_separation_m(0.5, p) == pytest.approx(0.7325)
    # At rest only the human's reaction-time travel and the margins remain: 0.16 + 0.06.
    assert protective_separation_m(0.0, p) == pytest.approx(0.22)
    assert protective_separation_m(-0.3, p) == pytest.approx(0.22)  # moving away counts as 0


def test_protective_stop_switches_exactly_at_S():
    p = SsmParams()
    for v_r in (0.0, 0.2, 0.8):
        s = float(protective_separation_m(v_r, p))
        assert protective_stop(s - 1e-6, v_r, p) and not protective_stop(s + 1e-6, v_r, p)
    # Faster toward the human: stop from farther away.
    assert protective_stop(0.5, 0.8, p) and not protective_stop(0.5, 0.0, p)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_speed_scaling_is_the_inverse_of_S_found_by_a_root_finder(seed):
    rng = np.random.default_rng(seed)
    p = SsmParams(human_speed_m_s=rng.uniform(0.5, 2.0), reaction_time_s=rng.uniform(0.02, 0.3),
                  braking_m_s2=rng.uniform(0.5, 10.0), intrusion_m=rng.uniform(0, 0.1),
                  sensor_uncertainty_m=rng.uniform(0, 0.1), robot_uncertainty_m=rng.uniform(0, 0.02))
    separation = rng.uniform(0.0, 3.0)
    v = float(max_approach_speed_m_s(separation, p))
    at_rest = float(protective_separation_m(0.0, p))
    if separation <= at_rest:
        assert v == 0.0
    else:
        oracle = brentq(lambda x: float(protective_separation_m(x, p)) - separation, 0.0, 100.0, xtol=1e-12)
        assert v == pytest.approx(oracle, rel=1e-9, abs=1e-12)
        assert not protective_stop(separation + 1e-9, v, p)


def test_braking_deceleration_is_the_worst_direction_of_the_joint_limits():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(3, 7))
    limits = rng.uniform(2.0, 20.0, 7)
    a = braking_deceleration_m_s2(J, limits)
    pinv = np.linalg.pinv(J)
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    # Per direction: the largest a with |pinv u a| <= limits joint by joint.
    per_direction = np.min(limits[None] / np.maximum(np.abs(u @ pinv.T), 1e-15), axis=1)
    assert per_direction.min() >= a * (1 - 1e-6)
    assert per_direction.min() == pytest.approx(a, rel=0.02)
    assert braking_deceleration_m_s2(J, 2 * limits) == pytest.approx(2 * a, rel=1e-9)
