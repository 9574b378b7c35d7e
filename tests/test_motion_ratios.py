"""A run's ratios to its motion limits, on trajectories whose derivatives are known in closed
form: cubics in time (exact backward differences), steps in velocity, constant joint rates
through a continuous joint's wrap, and the time-scaling law (ratios scale by 1/s, 1/s², 1/s³).
"""

import json
import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety.arm.motion_limits import MotionLimits, load_motion_limits
from cobotsafety.arm.robots import load_robot
from cobotsafety.experiments.motion_ratios import (OVER_LIMIT_RATIO, ee_derivatives, joint_derivatives,
                                                   motion_ratios)


def subtract(q0, q1):
    return q1 - q0


def fake_limits(velocity, acceleration, jerk, ee=(1.0, 2.0, 40.0)) -> MotionLimits:
    n = len(velocity)
    return MotionLimits("fake", tuple(f"j{i}" for i in range(n)), np.asarray(velocity, float),
                        np.asarray(acceleration, float), np.asarray(jerk, float), *ee, sources={})


LIMITS = fake_limits([2.0, 1.0, 3.0], [10.0, 5.0, 20.0], [500.0, 250.0, 1000.0])


def cubic(coefficients, t):
    """q(t) per joint for coefficients (4, n): c0 + c1 t + c2 t² + c3 t³."""
    c0, c1, c2, c3 = coefficients
    return c0 + np.outer(t, c1) + np.outer(t**2, c2) + np.outer(t**3, c3)


def test_cubic_in_time_gives_the_closed_form_differences():
    rng = np.random.default_rng(20)
    dt = 1e-3
    coefficients = rng.uniform(-1.0, 1.0, size=(4, 3)) * np.array([[1.0], [0.5], [2.0], [40.0]])
    t = np.arange(400) * dt
    d = joint_derivatives(cubic(coefficients, t), dt, subtract, from_rest=False)
    _, c1, c2, c3 = coefficients
    tk = t[1:, None]
    np.testing.assert_allclose(d.velocity, c1 + c2 * (2 * tk - dt) + c3 * (3 * tk**2 - 3 * tk * dt + dt**2),
                               rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(d.acceleration, 2 * c2 + 6 * c3 * (t[2:, None] - dt), rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(d.jerk, np.broadcast_to(6 * c3, d.jerk.shape), rtol=1e-5)
    assert (d.velocity_first_step, d.acceleration_first_step, d.jerk_first_step) == (1, 2, 3)

    r = motion_ratios(cubic(coefficients, t), dt, LIMITS, subtract, from_rest=False)
    v_exact = np.abs(c1 + c2 * (2 * tk - dt) + c3 * (3 * tk**2 - 3 * tk * dt + dt**2)) / LIMITS.velocity_rad_s
    a_exact = np.abs(2 * c2 + 6 * c3 * (t[2:, None] - dt)) / LIMITS.acceleration_rad_s2
    assert r.max_joint_velocity_ratio == pytest.approx(v_exact.max(), rel=1e-9)
    assert r.max_joint_acceleration_ratio == pytest.approx(a_exact.max(), rel=1e-6)
    assert r.max_joint_jerk_ratio == pytest.approx(np.max(np.abs(6 * c3) / LIMITS.jerk_rad_s3), rel=1e-5)
    step, joint = np.unravel_index(np.argmax(v_exact), v_exact.shape)
    assert r.max_joint_velocity_at == (step + 1, joint)
    step, joint = np.unravel_index(np.argmax(a_exact), a_exact.shape)
    assert r.max_joint_acceleration_at == (step + 2, joint)
    assert r.max_joint_jerk_at[1] == int(np.argmax(np.abs(6 * c3) / LIMITS.jerk_rad_s3))
    assert r.steps_over_acceleration_limit == int(np.count_nonzero(np.any(a_exact > 1.0, axis=1)))


def test_from_rest_is_the_path_with_its_start_held_before_it():
    """from_rest=True charges the first steps as if the arm had stood at q_path[0]."""
    rng = np.random.default_rng(7)
    q = np.cumsum(rng.normal(0.0, 1e-3, size=(50, 3)), axis=0) + rng.normal(size=3)
    held = np.vstack([q[:1], q[:1], q])
    rest = joint_derivatives(q, 1e-3, subtract, from_rest=True)
    inside = joint_derivatives(held, 1e-3, subtract, from_rest=False)
    np.testing.assert_array_equal(rest.velocity, inside.velocity[2:])
    np.testing.assert_allclose(rest.acceleration, inside.acceleration[1:], rtol=1e-12)
    np.testing.assert_allclose(rest.jerk, inside.jerk, rtol=1e-12)
    assert (rest.velocity_first_step, rest.acceleration_first_step, rest.jerk_first_step) == (1, 1, 1)


def test_a_step_in_velocity():
    """Constant v0 for 20 steps, then v1: one acceleration spike (v1-v0)/dt, a jerk pair +-(v1-v0)/dt²."""
    dt = 2e-3
    v0, v1 = np.array([0.5, -0.2, 1.0]), np.array([0.5, 0.3, 1.2])
    rates = np.vstack([np.tile(v0, (20, 1)), np.tile(v1, (30, 1))])
    q = np.vstack([np.zeros(3), np.cumsum(rates * dt, axis=0)])
    r = motion_ratios(q, dt, LIMITS, subtract, from_rest=False)
    jump = np.abs(v1 - v0)
    fastest = np.maximum(np.abs(v0), np.abs(v1))
    assert r.max_joint_velocity_ratio == pytest.approx(np.max(fastest / LIMITS.velocity_rad_s))
    assert r.max_joint_acceleration_ratio == pytest.approx(np.max(jump / dt / LIMITS.acceleration_rad_s2), rel=1e-9)
    assert r.max_joint_acceleration_at == (21, 1)
    assert r.max_joint_jerk_ratio == pytest.approx(np.max(jump / dt**2 / LIMITS.jerk_rad_s3), rel=1e-9)
    assert r.max_joint_jerk_at in {(21, 1), (22, 1)}
    assert r.steps_over_acceleration_limit == 1  # one step, although two joints jump
    mirrored = motion_ratios(-q, dt, LIMITS, subtract, from_rest=False)  # the same motion, every sign flipped
    np.testing.assert_allclose(ratios_tuple(mirrored)[:3].astype(float), ratios_tuple(r)[:3].astype(float), rtol=1e-12)
    assert mirrored.max_joint_acceleration_at == r.max_joint_acceleration_at
    # From rest the start is a jump too (joint 2 to 1.0 rad/s in one step: 25x its 20 rad/s²),
    # a second step over the limit; the worst is still joint 1's 50x in step 21.
    r = motion_ratios(q, dt, LIMITS, subtract)
    np.testing.assert_allclose(joint_derivatives(q, dt, subtract).acceleration[0], v0 / dt, rtol=1e-9)
    assert r.max_joint_acceleration_ratio == pytest.approx(0.5 / dt / 5.0, rel=1e-9)
    assert r.max_joint_acceleration_at == (21, 1)
    assert r.steps_over_acceleration_limit == 2


def test_a_command_at_the_limit_is_not_counted_over_it():
    """Exactly the acceleration limit every step (a ramp in velocity) is ratio 1.0, 0 steps over."""
    dt = 1e-3
    limits = fake_limits([100.0], [5.0], [1e9])
    velocity = 5.0 * dt * np.arange(1, 200)
    q = np.concatenate([[0.0], np.cumsum(velocity * dt)])[:, None]
    r = motion_ratios(q, dt, limits, subtract)
    assert r.max_joint_acceleration_ratio == pytest.approx(1.0, abs=1e-9)
    assert r.steps_over_acceleration_limit == 0
    q[150:] += 1e-9  # a nanometre more in one step: over, then under, counted once
    assert motion_ratios(q, dt, limits, subtract).steps_over_acceleration_limit == 1


def test_end_effector_cubic_from_rest():
    """p(t) = c t³ from rest: speed |c|(3t² - 3t dt + dt²), acceleration 6|c|(t - dt), jerk 6|c|."""
    dt = 1e-3
    c = np.array([3.0, -4.0, 12.0])  # |c| = 13
    t = np.arange(300) * dt
    p = np.outer(t**3, c)
    q = np.zeros((300, 3))
    r = motion_ratios(q, dt, LIMITS, subtract, p_ee_path=p)
    end = t[-1]
    assert r.max_ee_speed_m_s == pytest.approx(13.0 * (3 * end**2 - 3 * end * dt + dt**2), rel=1e-9)
    assert r.max_ee_acceleration_m_s2 == pytest.approx(6 * 13.0 * (end - dt), rel=1e-6)
    assert r.max_ee_jerk_m_s3 == pytest.approx(6 * 13.0, rel=1e-5)
    e = ee_derivatives(p, dt)
    np.testing.assert_allclose(e.jerk[:2], [c, 5 * c], rtol=1e-5)  # the start from rest: c, then 5c, then 6c
    assert r.as_json()["max_ee_jerk_m_s3"] == r.max_ee_jerk_m_s3
    # the hand's ratios: each norm over the robot's own end-effector limit (LIMITS: 1 m/s, 2 m/s², 40 m/s³)
    assert r.max_ee_speed_ratio == pytest.approx(r.max_ee_speed_m_s / 1.0, rel=1e-12)
    assert r.max_ee_acceleration_ratio == pytest.approx(6 * 13.0 * (end - dt) / 2.0, rel=1e-6)
    assert r.max_ee_jerk_ratio == pytest.approx(6 * 13.0 / 40.0, rel=1e-5)
    other = motion_ratios(q, dt, fake_limits([2.0, 1.0, 3.0], [10.0, 5.0, 20.0], [500.0, 250.0, 1000.0],
                                             ee=(2.0, 4.0, 78.0)), subtract, p_ee_path=p)
    assert other.max_ee_jerk_ratio == pytest.approx(1.0, rel=1e-5)  # the limit, not a constant
    assert other.max_ee_speed_ratio == pytest.approx(r.max_ee_speed_ratio / 2.0, rel=1e-12)
    assert motion_ratios(q, dt, LIMITS, subtract).max_ee_jerk_ratio is None  # no hand path, no hand ratio


@pytest.fixture(scope="module")
def kinova():
    model = load_robot("kinova")[0]
    names = [model.names[j] for j in range(1, model.njoints)]
    return model, load_motion_limits("kinova", names)


def test_continuous_joint_through_its_wrap_uses_the_tangent_difference(kinova):
    """Constant joint rates for 1 s, joint 1 (continuous, cos/sin) crossing +-pi: the velocity
    ratio is the rate over the limit and the acceleration is 0 inside the run."""
    model, limits = kinova
    dt = 1e-3
    rate = 0.9 * limits.velocity_rad_s * np.array([1, -1, 1, -1, 1, -1])
    q = pin.integrate(model, pin.neutral(model), np.r_[3.0, 0, 0, 0, 0, 0])  # joint 1 near pi
    path = [q]
    for _ in range(1000):
        path.append(pin.integrate(model, path[-1], rate * dt))
    path = np.array(path)
    assert path.shape == (1001, model.nq) and model.nq == 9
    r = motion_ratios(path, dt, limits, lambda a, b: pin.difference(model, a, b), from_rest=False)
    assert r.max_joint_velocity_ratio == pytest.approx(0.9, rel=1e-9)
    assert r.max_joint_acceleration_ratio < 1e-6 and r.max_joint_jerk_ratio < 1e-3
    assert r.steps_over_acceleration_limit == 0
    with pytest.raises(ValueError, match=r"difference gives 9 velocities but 'kinova' has limits for 6 joints"):
        motion_ratios(path, dt, limits, subtract)


def ratios_tuple(r):
    return np.array([r.max_joint_velocity_ratio, r.max_joint_acceleration_ratio, r.max_joint_jerk_ratio,
                     r.max_ee_speed_m_s, r.max_ee_acceleration_m_s2, r.max_ee_jerk_m_s3,
                     r.max_ee_speed_ratio, r.max_ee_acceleration_ratio, r.max_ee_jerk_ratio])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(0.05, 20.0), from_rest=st.booleans())
def test_scaling_time_by_s_scales_the_ratios_by_inverse_powers_of_s(seed, scale, from_rest):
    rng = np.random.default_rng(seed)
    steps = int(rng.integers(4, 60))
    q = np.cumsum(rng.normal(0.0, 1e-2, size=(steps, 3)), axis=0)
    p = np.cumsum(rng.normal(0.0, 1e-3, size=(steps, 3)), axis=0)
    dt = float(rng.uniform(1e-3, 1e-2))
    base = motion_ratios(q, dt, LIMITS, subtract, p, from_rest=from_rest)
    slow = motion_ratios(q, dt * scale, LIMITS, subtract, p, from_rest=from_rest)
    powers = np.array([1, 2, 3, 1, 2, 3, 1, 2, 3])
    np.testing.assert_allclose(ratios_tuple(slow), ratios_tuple(base) / scale**powers, rtol=1e-9)
    # The worst step and joint do not depend on the clock, unless two candidates tie to rounding.
    v = joint_derivatives(q, dt, subtract, from_rest).velocity
    if np.ptp(np.sort((np.abs(v) / LIMITS.velocity_rad_s).ravel())[-2:]) > 1e-9:
        assert slow.max_joint_velocity_at == base.max_joint_velocity_at


def test_as_json_has_exactly_the_run_keys_and_serialises():
    q = np.zeros((5, 3))
    r = motion_ratios(q, 1e-3, LIMITS, subtract)
    assert list(r.as_json()) == ["max_joint_velocity_ratio", "max_joint_acceleration_ratio",
                                 "max_joint_jerk_ratio", "max_ee_jerk_m_s3", "max_ee_speed_ratio",
                                 "max_ee_acceleration_ratio", "max_ee_jerk_ratio"]
    assert json.loads(json.dumps(r.as_json())) == {"max_joint_velocity_ratio": 0.0, "max_joint_acceleration_ratio": 0.0,
                                                   "max_joint_jerk_ratio": 0.0, "max_ee_jerk_m_s3": None,
                                                   "max_ee_speed_ratio": None, "max_ee_acceleration_ratio": None,
                                                   "max_ee_jerk_ratio": None}


@pytest.mark.parametrize("dt", [0.0, -1e-3, math.nan, math.inf, True, "1e-3"])
def test_bad_period_is_refused(dt):
    with pytest.raises(ValueError, match="dt_s must be a finite positive period"):
        motion_ratios(np.zeros((5, 3)), dt, LIMITS, subtract)


def test_bad_paths_are_refused_with_the_step_named():
    q = np.zeros((10, 3))
    q[6, 1] = math.nan
    with pytest.raises(ValueError, match=r"q_path\[6\] is not finite"):
        motion_ratios(q, 1e-3, LIMITS, subtract)
    with pytest.raises(ValueError, match=r"q_path must have shape \(T, n\) with T >= 2, got \(1, 3\)"):
        motion_ratios(np.zeros((1, 3)), 1e-3, LIMITS, subtract)
    with pytest.raises(ValueError, match=r"T >= 4, got \(3, 3\)"):
        motion_ratios(np.zeros((3, 3)), 1e-3, LIMITS, subtract, from_rest=False)
    with pytest.raises(ValueError, match=r"p_ee_path has 4 samples, q_path 5"):
        motion_ratios(np.zeros((5, 3)), 1e-3, LIMITS, subtract, p_ee_path=np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"p_ee_path must have shape \(T, 3\)"):
        motion_ratios(np.zeros((5, 3)), 1e-3, LIMITS, subtract, p_ee_path=np.zeros((5, 2)))
    calls = []

    def fails_at_the_third_pair(a, b):
        calls.append(1)
        return np.full(3, np.inf) if len(calls) == 3 else b - a

    with pytest.raises(ValueError, match=r"difference\(q_path\[2\], q_path\[3\]\) is not finite"):
        motion_ratios(np.zeros((5, 3)), 1e-3, LIMITS, fails_at_the_third_pair)


def test_over_limit_threshold_is_just_above_one():
    assert 1.0 < OVER_LIMIT_RATIO < 1.0 + 1e-6
