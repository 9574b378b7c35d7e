"""``ArmController`` without a human: loading every robot, random teleoperation that never
crosses a limitation and stays within the robot's motion limits, recovery from inside a zone,
singular poses, bad input, the reach, sliding along an edge, the speed cap, long periods.

Distances come from the oracles (pinocchio's kinematics and numpy geometry,
``tests/oracles``), never from the compiled step; the motion from the commanded joint path
(``experiments.motion_ratios``)."""

from __future__ import annotations

import logging
from functools import lru_cache

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.controller import MAX_PERIOD_S, MAX_STEP_S, ArmController, StepError
from cobotsafety.arm.limitations import HalfSpaceZone, JointPositionLimits, ReachLimits, SphereZone
from cobotsafety.arm.robots import ROBOTS
from cobotsafety.errors import UnknownRobotError
from cobotsafety.experiments.motion_ratios import OVER_LIMIT_RATIO, motion_ratios
from oracles import limitations as oracle
from oracles.kinematics import Kinematics

ROBOT_NAMES = list(ROBOTS)
CROSSING_M = 1e-9
"""A distance [m or rad] counts as crossed below ``min(before, 0)`` by more than this: the
oracle and the compiled geometry agree to ~1e-12 (``test_arm_limitations.py``)."""


def oracle_distances(controller: ArmController, q: np.ndarray | None = None) -> np.ndarray:
    """Every distance of every limitation but the human (joints [rad], reach, table, zones
    [m]) at ``q`` (default: the controller's), exact, from the oracles."""
    kin = Kinematics(controller.model, controller.state.q if q is None else q)
    return np.concatenate([oracle.exact_distances(lim, kin, oracle.Human.none())
                           for lim in controller.limitations[:-1]])


def drive(controller: ArmController, v, steps: int, dt_s: float, method: str = "anticipative"):
    return [controller.step(np.asarray(v, dtype=float), dt_s, method) for _ in range(steps)]


def test_every_robot_loads_by_name_and_an_unknown_name_lists_the_known_ones():
    for name in ROBOT_NAMES:
        controller = ArmController(name)
        assert controller.model.name == name and controller.state.q.shape == (controller.model.nq,)
        np.testing.assert_allclose(controller.state.q, controller.model.home_q)
        kin = Kinematics(controller.model, controller.model.home_q)  # the state's kinematics: pinocchio's
        np.testing.assert_allclose(controller.p_base_ee_m, kin.p_ee, atol=1e-12)
        assert np.all(oracle_distances(controller) > 0.0), name  # home is clear of every limitation
    with pytest.raises(UnknownRobotError, match=", ".join(ROBOT_NAMES)):
        ArmController("kr6")


def test_continuous_joints_stay_on_the_unit_circle():
    controller = ArmController("kinova")
    assert (controller.model.nq, controller.model.nv) == (9, 6)
    drive(controller, [0.1, 0.2, 0.0], 300, 0.004)
    model, q = controller.model.model, controller.state.q
    continuous = [model.joints[j] for j in range(1, model.njoints) if model.joints[j].nq == 2]
    assert continuous
    for joint in continuous:
        assert np.hypot(*q[joint.idx_q:joint.idx_q + 2]) == pytest.approx(1.0, abs=1e-12)


# ---- random teleoperation ----------------------------------------------------------------------
TELEOP_DT_S = 0.002
TELEOP_STEPS = 1500
HOLD_STEPS = 150


def random_teleoperation(robot: str, seed: int):
    """``TELEOP_STEPS`` steps of ``TELEOP_DT_S``: a random direction held for ``HOLD_STEPS``
    steps, speeds up to 1 m/s (twice the cap), among the demo's zones, the table, the reach and
    the joint limits. Returns the controller, the reports, the joint and hand paths, the worst
    crossing [m or rad] and the smallest distance met."""
    rng = np.random.default_rng(seed)
    controller = ArmController(robot)
    before = oracle_distances(controller)
    q_path, p_path, reports = [controller.state.q.copy()], [controller.p_base_ee_m], []
    worst, nearest = 0.0, float(before.min())
    v = np.zeros(3)
    for i in range(TELEOP_STEPS):
        if i % HOLD_STEPS == 0:
            v = rng.normal(size=3)
            v *= rng.uniform(0.1, 1.0) / np.linalg.norm(v)
        reports.append(controller.step(v, TELEOP_DT_S))
        assert np.all(np.isfinite(controller.state.q)), (robot, i)
        after = oracle_distances(controller)
        worst = max(worst, float(np.max(np.minimum(before, 0.0) - after)))
        nearest = min(nearest, float(after.min()))
        before = after
        q_path.append(controller.state.q.copy())
        p_path.append(controller.p_base_ee_m)
    return controller, reports, np.array(q_path), np.array(p_path), worst, nearest


@lru_cache(maxsize=None)
def teleoperation_run(robot: str):
    """One seeded run per robot, shared by the tests below."""
    return random_teleoperation(robot, seed=3)


def ratios_of(robot: str):
    controller, _, q_path, p_path, _, _ = teleoperation_run(robot)
    model = controller.model
    ratios = motion_ratios(q_path, TELEOP_DT_S, model.limits, lambda a, b: pin.difference(model.model, a, b), p_path)
    words = (f"{robot}: joint velocity {ratios.max_joint_velocity_ratio:.4f} of its limit at (step, joint) "
             f"{ratios.max_joint_velocity_at}, acceleration {ratios.max_joint_acceleration_ratio:.4f} at "
             f"{ratios.max_joint_acceleration_at}, jerk {ratios.max_joint_jerk_ratio:.4f} at {ratios.max_joint_jerk_at}; "
             f"hand {ratios.max_ee_speed_m_s:.3f} m/s, {ratios.max_ee_acceleration_m_s2:.3f} m/s^2, "
             f"{ratios.max_ee_jerk_m_s3:.1f} m/s^3; {controller.smoothness_steps} step(s) gave up smoothness")
    return ratios, model.limits, controller, words


@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_random_teleoperation_never_crosses_a_limitation(robot):
    controller, reports, _, _, worst, nearest = teleoperation_run(robot)
    assert worst <= CROSSING_M, f"{robot}: a limitation crossed by {worst:.3g}"
    assert nearest < 0.05, f"{robot}: the run never came near a limitation ({nearest:.3f})"  # it was exercised
    # The safety net (the step's bisection) is a backstop: the filter keeps the limits itself.
    assert sum(r.extras["net_scale"] < 1.0 for r in reports) <= 0.01 * len(reports)


XARM7_CAP = ("xarm7 (seed 3, dt 2 ms): the 0.5 m/s speed cap gives way from step 56 (0.11 s) on, the hand runs "
             "at the robot's own 1.0 m/s; that hard limit then overrides the motion limits: joint acceleration "
             "6.6x, jerk 112x the limits, 152 of 1500 steps give up smoothness. Likely cause: the hand's jerk "
             "limit (100 m/s^3 against 50 m/s^2) in the end-effector motion box, which has no ramp-down term "
             "before the cap (step_kernel.motion_box gets vel=inf for the hand)")


def _xfail(reason: str):
    return pytest.mark.xfail(strict=True, reason=reason)


@pytest.mark.parametrize("robot", [pytest.param(r, marks=_xfail(XARM7_CAP)) if r == "xarm7" else r
                                   for r in ROBOT_NAMES])
def test_random_teleoperation_keeps_the_joint_motion_limits(robot):
    ratios, _, controller, words = ratios_of(robot)
    assert ratios.max_joint_velocity_ratio <= OVER_LIMIT_RATIO, words
    assert ratios.max_joint_acceleration_ratio <= OVER_LIMIT_RATIO, words
    assert ratios.max_joint_jerk_ratio <= OVER_LIMIT_RATIO, words
    assert controller.smoothness_steps == 0, words


EE_ACCELERATION = ("{robot} (seed 3, dt 2 ms): the hand's executed acceleration (second differences of its "
                   "positions) reaches {value} m/s^2 against the robot's 2.0 m/s^2, at ~0.47 m/s (also at dt 1 "
                   "and 4 ms for z1): the kernel limits J qddot to EE_MOTION_SHARE (0.9) of the limit, but the "
                   "rest (dJ/dt qdot, ~0.35 m/s^2 at 0.5 m/s on these arms) is more than the 10 % left for it")
EE_XFAIL = {"z1": EE_ACCELERATION.format(robot="z1", value="2.156"),
            "iiwa": EE_ACCELERATION.format(robot="iiwa", value="2.180"), "xarm7": XARM7_CAP}


@pytest.mark.parametrize("robot", [pytest.param(r, marks=_xfail(EE_XFAIL[r])) if r in EE_XFAIL else r
                                   for r in ROBOT_NAMES])
def test_random_teleoperation_keeps_the_hand_within_its_limits_and_the_cap(robot):
    ratios, limits, controller, words = ratios_of(robot)
    cap = min(controller.settings.max_speed_m_s, limits.ee_speed_m_s)
    assert ratios.max_ee_speed_m_s <= cap * 1.03, words  # executed: a few % of curvature over a step
    assert ratios.max_ee_acceleration_m_s2 <= limits.ee_acceleration_m_s2 * OVER_LIMIT_RATIO, words
    assert ratios.max_ee_jerk_m_s3 <= limits.ee_jerk_m_s3 * OVER_LIMIT_RATIO, words
