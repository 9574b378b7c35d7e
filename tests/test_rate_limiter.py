"""The robot's rate limiter (``arm.rate_limiter``, the campaign's rate-limited plant) and the
controller's measured state (``ArmController.set_measured_state``).

Oracles: libfranka's per-joint rule transcribed one joint at a time in plain Python (at 1 ms,
where its gain ``J / A`` needs no cap), pinocchio's forward kinematics, and finite differences of
the hand's position along a constant-acceleration joint path."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety.arm.rate_limiter import limit_rate
from cobotsafety.arm.robot_model import RobotModel


def _libfranka_joint(v_max, a_max, j_max, commanded, last_v, last_a, dt):
    """One joint of libfranka's joint-velocity rate limiter, written out (its ``kDeltaT`` = dt)."""
    jerk = ((commanded - last_v) / dt - last_a) / dt
    a = last_a + max(min(jerk, j_max), -j_max) * dt
    upper = min((j_max / a_max) * (v_max - last_v), a_max)
    lower = max((j_max / a_max) * (-v_max - last_v), -a_max)
    return last_v + max(min(a, upper), lower) * dt


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_the_limiter_is_libfrankas_rule_at_one_millisecond(robot):
    """At libfranka's own 1 ms (``J / A`` times dt below 1 for both robots: no cap) the limiter
    equals the rule joint by joint, on states within the limits and commands far beyond them."""
    limits = RobotModel.load(robot, "paper").limits
    rng = np.random.default_rng(20261205)
    dt = 1e-3
    assert np.all(limits.jerk_rad_s3 / limits.acceleration_rad_s2 * dt < 1.0)
    changed = 0  # joints the limiter changed
    for _ in range(400):
        v = rng.uniform(-1, 1, limits.velocity_rad_s.size) * limits.velocity_rad_s
        a = rng.uniform(-1, 1, v.size) * limits.acceleration_rad_s2
        push = rng.normal(0, 1, v.size) * limits.jerk_rad_s3 * dt * dt * rng.choice([0.3, 3.0, 3000.0])
        command = v + a * dt + push  # the last acceleration held, pushed by a jerk within or beyond the limit
        got = limit_rate(limits, command, v, a, dt)
        want = [_libfranka_joint(*(float(x[i]) for x in (limits.velocity_rad_s, limits.acceleration_rad_s2,
                                                          limits.jerk_rad_s3, command, v, a)), dt)
                for i in range(v.size)]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        changed += int(np.sum(np.abs(got - command) > 1e-12))
    assert 0.2 < changed / (400 * v.size) < 0.8  # joints let through and joints limited, both


@settings(max_examples=300, deadline=None)
@given(robot=st.sampled_from(["panda", "iiwa"]), dt=st.floats(1e-4, 1e-2), seed=st.integers(0, 2**32 - 1),
       scale=st.floats(0.0, 50.0))
def test_the_arm_following_the_limiter_stays_within_its_speed_and_acceleration(robot, dt, seed, scale):
    """From any state within the limits, whatever the command, the velocity let through is
    within the speed limit and reached at most at the acceleration limit, at any period (at 275
    Hz the Panda's ``J / A`` times dt is 1.8: uncapped, the speed would overshoot its limit)."""
    limits = RobotModel.load(robot, "paper").limits
    rng = np.random.default_rng(seed)
    v = rng.uniform(-1, 1, limits.velocity_rad_s.size) * limits.velocity_rad_s
    a = rng.uniform(-1, 1, v.size) * limits.acceleration_rad_s2
    command = v + rng.normal(0, 1, v.size) * scale * limits.velocity_rad_s
    got = limit_rate(limits, command, v, a, dt)
    assert np.all(np.abs(got) <= limits.velocity_rad_s * (1 + 1e-12))
    assert np.all(np.abs(got - v) / dt <= limits.acceleration_rad_s2 * (1 + 1e-9))


@settings(max_examples=200, deadline=None)
@given(robot=st.sampled_from(["panda", "iiwa"]), dt=st.floats(1e-4, 1e-2), seed=st.integers(0, 2**32 - 1))
def test_a_command_within_the_limits_passes_unchanged(robot, dt, seed):
    """A command whose jerk and acceleration are within the limits (and the speed-dependent
    bound) is let through bit for bit: the ideal and the rate-limited plants agree on every
    step the filter kept within the limits."""
    limits = RobotModel.load(robot, "paper").limits
    rng = np.random.default_rng(seed)
    v = rng.uniform(-0.5, 0.5, limits.velocity_rad_s.size) * limits.velocity_rad_s
    a = rng.uniform(-0.2, 0.2, v.size) * limits.acceleration_rad_s2
    gain = np.minimum(limits.jerk_rad_s3 / limits.acceleration_rad_s2, 1 / dt)
    room = np.minimum(limits.jerk_rad_s3 * dt, 0.2 * np.minimum(limits.acceleration_rad_s2, gain * 0.5 *
                                                                 limits.velocity_rad_s))
    next_a = a + rng.uniform(-0.5, 0.5, v.size) * room
    command = v + next_a * dt
    assert np.array_equal(limit_rate(limits, command, v, a, dt), command)


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_a_measured_state_is_where_the_next_step_starts(robot):
    """``set_measured_state``: the kinematics are pinocchio's at ``q``, the velocity and
    acceleration are the next step's starting state, the hand's velocity is the derivative of
    its position along ``q + qdot t`` and its acceleration the joints' part, ``J qddot`` (central
    differences)."""
    from cobotsafety.arm.controller import ArmController

    arm = ArmController(robot, zones=[], capsules="paper")
    model = arm.model.model
    rng = np.random.default_rng(7)
    q = arm.model.home_q + rng.uniform(-0.3, 0.3, model.nq)
    qdot = rng.uniform(-0.5, 0.5, model.nv)
    qddot = rng.uniform(-2, 2, model.nv)
    arm.set_measured_state(q, qdot, qddot)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    np.testing.assert_allclose(arm.state.q, q, atol=0)
    np.testing.assert_allclose(arm.state.p_world_ee, data.oMf[arm.model.ee_frame_id].translation, atol=1e-12)
    np.testing.assert_array_equal(arm.joint_velocity_rad_s, qdot)
    np.testing.assert_array_equal(arm.joint_acceleration_rad_s2, qddot)

    def hand(t):
        d = model.createData()
        pin.framesForwardKinematics(model, d, pin.integrate(model, q, qdot * t))
        return d.oMf[arm.model.ee_frame_id].translation.copy()

    h = 1e-4
    velocity = (hand(h) - hand(-h)) / (2 * h)

    def hand_velocity(q0, v):  # the hand's velocity at q0 moving at v (central differences)
        d = model.createData()
        pin.framesForwardKinematics(model, d, pin.integrate(model, q0, v * h))
        ahead = d.oMf[arm.model.ee_frame_id].translation.copy()
        pin.framesForwardKinematics(model, d, pin.integrate(model, q0, -v * h))
        return (ahead - d.oMf[arm.model.ee_frame_id].translation) / (2 * h)
    nq, nv = model.nq, model.nv
    stored = arm._state_f  # the kernel's state: q, qdot, qddot, the hand's velocity and acceleration
    assert stored.shape == (nq + 2 * nv + 6,)
    np.testing.assert_allclose(stored[nq + 2 * nv:nq + 2 * nv + 3], velocity, atol=1e-7)
    # the hand's acceleration as the joints give it (J qddot: the velocity's change along qddot,
    # central differences; the path's curvature left out, as the docstring says)
    qdot_of = lambda t: hand_velocity(q, qdot + qddot * t)  # noqa: E731
    np.testing.assert_allclose(stored[nq + 2 * nv + 3:], (qdot_of(h) - qdot_of(-h)) / (2 * h), atol=1e-6)
    report = arm.step(np.zeros(3), 1e-3, "off")  # a step from it: braking from qdot, within the limits
    assert math.isfinite(report.min_distance_m or 0.0)
    moved = arm.model.difference(q, arm.state.q) / 1e-3
    assert np.all(np.abs(moved - qdot) <= arm.model.limits.acceleration_rad_s2 * 1e-3 * (1 + 1e-6))


@pytest.mark.parametrize("bad", [dict(q=np.nan), dict(qdot=np.inf), dict(shape=True)])
def test_a_measured_state_that_is_not_finite_or_misshaped_is_refused(bad):
    from cobotsafety.arm.controller import ArmController

    arm = ArmController("panda", zones=[], capsules="paper")
    q, qdot, qddot = arm.state.q.copy(), np.zeros(7), np.zeros(7)
    if "q" in bad:
        q[2] = bad["q"]
    if "qdot" in bad:
        qdot[0] = bad["qdot"]
    if "shape" in bad:
        qddot = np.zeros(6)
    with pytest.raises(ValueError, match="measured state"):
        arm.set_measured_state(q, qdot, qddot)
    np.testing.assert_array_equal(arm.state.q, arm.model.home_q)  # nothing changed


def test_a_measured_state_beyond_a_joint_limit_is_kept_where_it_is():
    """A real arm (or the rate-limited plant) may be past a joint's software limit: the state is
    put there, not at the end stop (its kinematics are pinocchio's at the measured ``q``), and
    the next step moves the joint back toward its range."""
    from cobotsafety.arm.controller import ArmController

    arm = ArmController("iiwa", zones=[], capsules="paper")
    model = arm.model.model
    q = arm.model.home_q.copy()
    q[1] = arm.model.upper[1] + 0.01
    arm.set_measured_state(q, np.zeros(model.nv), np.zeros(model.nv))
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    np.testing.assert_array_equal(arm.state.q, q)
    np.testing.assert_allclose(arm.state.p_world_ee, data.oMf[arm.model.ee_frame_id].translation, atol=1e-12)
    arm.step(np.zeros(3), 1e-3, "anticipative")
    assert arm.model.upper[1] < arm.state.q[1] < q[1]


def test_a_command_of_the_wrong_size_is_refused_in_one_line():
    """The compiled rule reads nv entries of each vector: a shorter one is a clear error, never
    a read past its end."""
    limits = RobotModel.load("panda", "paper").limits
    n = limits.velocity_rad_s.size
    with pytest.raises(ValueError, match=r"qdot_last must have shape \(7,\)"):
        limit_rate(limits, np.zeros(n), np.zeros(n - 1), np.zeros(n), 1e-3)
    with pytest.raises(ValueError, match="qdot_commanded"):
        limit_rate(limits, np.zeros((n, 1)), np.zeros(n), np.zeros(n), 1e-3)
