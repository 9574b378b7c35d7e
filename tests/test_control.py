"""Human-aware motion: the human constraint against finite differences, a moving human,
the anti-windup PI, ISO/TS 15066 numbers by hand, the potential field, the experiment."""

from __future__ import annotations

import logging

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.step import ArmParams, mapping
from cobotsafety.control.controllers import HumanAwareArm
from cobotsafety.control.human_constraint import HumanCapsulesConstraint
from cobotsafety.control.pi import AntiWindupPI
from cobotsafety.control.potential_field import PotentialFieldParams, repulsion_speed
from cobotsafety.human.body import HumanCapsules

logging.getLogger("cobotsafety.filter").setLevel(logging.ERROR)


def capsule(p0, p1, radius, v_h=None, t_s=0.0) -> HumanCapsules:
    """One human capsule; ``v_h`` (3,): both end points' velocity (None: estimated by the arm)."""
    v = None if v_h is None else np.array([v_h], dtype=float)
    return HumanCapsules([p0], [p1], [radius], ("torso",), t_s=t_s, v0_b_m_s=v, v1_b_m_s=v)


def test_human_constraint_normal_matches_finite_differences_along_the_command():
    arm = HumanAwareArm("panda")
    state = arm.state
    rng = np.random.default_rng(0)
    M, c = mapping(state, ArmParams(), None)
    eps = 1e-6
    checked = 0
    for _ in range(20):
        p = state.p_world_ee + rng.normal(size=3) * 0.15
        human = HumanCapsulesConstraint(activation_m=5.0)
        human.set_human(capsule(p, p + rng.normal(size=3) * 0.2, 0.08))
        measures = human.measures(state)
        v = rng.normal(size=3)
        q0 = state.q.copy()
        values = []
        for sign in (1, -1):
            state.q = pin.integrate(state.model, q0, sign * eps * (M @ v))
            state.update()
            values.append(human.measures(state).distance)
        state.q = q0
        state.update()
        fd = (values[0] - values[1]) / (2 * eps)
        smooth = np.abs(values[0] + values[1] - 2 * measures.distance) < 1e-8
        np.testing.assert_allclose(((measures.A @ M) @ v)[smooth], fd[smooth], rtol=1e-4, atol=1e-6)
        checked += int(smooth.sum())
    assert checked > 50


def test_human_velocity_enters_as_the_rate_of_the_distance():
    arm = HumanAwareArm("panda")
    state = arm.state
    p = state.p_world_ee + np.array([0.0, 0.35, 0.0])
    v_h = np.array([0.0, -0.5, 0.0])  # walking straight at the hand
    human = HumanCapsulesConstraint()
    human.set_human(capsule(p, p + [0, 0, 0.3], 0.1, v_h=v_h))
    m = human.measures(state)
    dt = 1e-6
    moved = HumanCapsulesConstraint()
    moved.set_human(capsule(p + v_h * dt, p + [0, 0, 0.3] + v_h * dt, 0.1))
    fd = (moved.measures(state).distance - m.distance) / dt
    np.testing.assert_allclose(m.rate, fd, rtol=1e-4, atol=1e-6)


def moving_human_run(controller, steps=900, dt=0.004):
    arm = HumanAwareArm("panda")
    start = arm.state.p_world_ee + np.array([0.0, 0.75, 0.0])
    distances, stopped = [], []
    for i in range(steps):
        # 0.3 m/s toward the robot's hand for 1.5 s, then the human stands there.
        p = start + np.array([0.0, -0.3, 0.0]) * min(i * dt, 1.5)
        arm.set_human(capsule(p, p + [0.0, 0.0, 0.4], 0.12, t_s=i * dt))
        result = arm.step(np.zeros(3), dt, controller)  # the robot is asked to hold still
        distances.append(result.min_distance_m)
        stopped.append(result.report.stopped)
    return np.array(distances), np.array(stopped)


def test_moving_human_anticipative_keeps_the_critical_distance_and_stop_halts():
    critical = HumanCapsulesConstraint().critical_m
    distances, _ = moving_human_run("anticipative")
    assert distances.min() >= critical - 1e-4  # gives way every step
    d_stop, stopped = moving_human_run("stop")
    assert stopped[-100:].all()  # halts ...
    assert d_stop.min() < critical - 0.05  # ... and the human closes in on it


def test_pi_anti_windup_saturates_and_recovers():
    pi = AntiWindupPI(kp_per_s=2.0, ki_per_s2=1.0, limit=0.3)
    for _ in range(2000):  # 4 s far from the target: saturated
        out = pi.update(np.array([1.0, 0.0, 0.0]), 0.002)
        assert np.linalg.norm(out) <= 0.3 + 1e-12
    assert pi.saturated
    assert np.linalg.norm(pi.integral) < 0.05  # no windup
    out = pi.update(np.array([-0.01, 0.0, 0.0]), 0.002)  # the target is passed: reverse at once
    assert out[0] < 0.0 and not pi.saturated
    naive_integral = 2000 * 0.002  # what an unclamped integrator would hold (4 m.s)
    assert naive_integral * pi.ki_per_s2 > 1.0  # which would have overshot for seconds


def test_ssm_slows_the_approach_but_not_the_retreat():
    # About 0.33 m between the hand's capsule and the human: S (braking at 3 m/s^2) allows
    # ~0.17 m/s toward them. One step, so without the acceleration bound (the SSM layer alone).
    params = ArmParams(max_accel_m_s2=np.inf)
    arm = HumanAwareArm("panda", human=HumanCapsulesConstraint(activation_m=2.0, critical_m=0.05), params=params)
    p = arm.state.p_world_ee + np.array([0.0, 0.47, 0.0])
    arm.set_human(capsule(p, p, 0.05))
    toward = arm.step(np.array([0.0, 0.3, 0.0]), 0.002, "anticipative", ssm=True)
    assert 0.0 < toward.report.v_executed_m_s[1] < 0.2  # limited toward the human
    arm2 = HumanAwareArm("panda", human=HumanCapsulesConstraint(activation_m=2.0, critical_m=0.05), params=params)
    arm2.set_human(capsule(p, p, 0.05))
    away = arm2.step(np.array([0.0, -0.3, 0.0]), 0.002, "anticipative", ssm=True)
    np.testing.assert_allclose(away.report.v_commanded_m_s, [0.0, -0.3, 0.0], atol=1e-9)  # not slowed


def test_a_larger_stale_human_never_lets_the_robot_approach_faster():
    speeds = []
    for radius in (0.05, 0.15, 0.3):  # the degraded model grows while the sensors are silent
        arm = HumanAwareArm("panda")
        p = arm.state.p_world_ee + np.array([0.0, 0.7, 0.0])
        arm.set_human(capsule(p, p, radius))
        result = arm.step(np.array([0.0, 0.4, 0.0]), 0.004, "anticipative")
        speeds.append(result.report.v_executed_m_s[1])
    assert speeds[0] >= speeds[1] - 1e-9 >= speeds[2] - 2e-9


def test_repulsion_magnitude_is_eq_18():
    p = PotentialFieldParams(critical_m=0.2, influence_m=0.3, k_rep_m_s=0.1, max_repulsion_m_s=10.0)
    assert repulsion_speed(0.6, p) == 0.0
    assert repulsion_speed(0.35, p) == pytest.approx(0.1 * (0.3 / 0.15 - 1))
    assert repulsion_speed(0.2, p) == p.max_repulsion_m_s
