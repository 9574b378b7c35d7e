"""The human-aware controllers under teleoperation (``HumanAwareTeleop``): the user's command
replaces the nominal path; the human, the zones and SSM hold for every controller."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cobotsafety.arm.zones import BoxZone
from cobotsafety.control.human_aware import HumanAwareTeleop
from cobotsafety.geometry.capsule import capsule_distance
from cobotsafety.human.body import HumanCapsules
from cobotsafety.teleoperated import Teleoperated

logging.getLogger("cobotsafety.filter").setLevel(logging.ERROR)
DT = 0.004


def human_beside(robot: HumanAwareTeleop, t_s: float = 0.0, offset=(0.0, 0.55, 0.0)) -> HumanCapsules:
    p = robot.p_base_ee_m + np.asarray(offset)
    return HumanCapsules([p + [0, 0, -0.3]], [p + [0, 0, 0.4]], [0.12], ("torso",), t_s=t_s)


def separation(robot: HumanAwareTeleop, human: HumanCapsules) -> float:
    """Oracle: every robot capsule but the base against the human, straight from the geometry."""
    s = robot.state
    d, _, _ = capsule_distance(s.capsule_p0[1:, None], s.capsule_p1[1:, None], s.capsule_radius[1:, None],
                               human.p0_b_m[None], human.p1_b_m[None], human.radius_m[None])
    return float(d.min())


def drive(robot, human, v, method, steps):
    distances, reports = [], []
    for i in range(steps):
        robot.set_human(human)
        reports.append(robot.step(v, DT, method))
        distances.append(separation(robot, human))
    return np.array(distances), reports


def test_is_teleoperated_and_reports_the_human_distance():
    robot = HumanAwareTeleop("panda")
    assert isinstance(robot, Teleoperated)
    human = human_beside(robot)
    robot.set_human(human)
    report = robot.step(np.zeros(3), DT, "anticipative")
    assert report.min_distance_m == pytest.approx(separation(robot, human), abs=1e-9)
    robot.set_human(None)
    assert robot.step(np.zeros(3), DT, "anticipative").min_distance_m is None


def test_anticipative_slides_past_the_human_and_off_runs_into_them():
    v = np.array([0.08, 0.2, 0.0])  # mostly at the human, a little along them
    critical = HumanAwareTeleop("panda").arm.human.critical_m
    robot = HumanAwareTeleop("panda")
    human = human_beside(robot)
    start = robot.p_base_ee_m
    distances, reports = drive(robot, human, v, "anticipative", 500)
    assert distances.min() >= critical - 1e-6
    assert any(name.startswith("human") for r in reports for name in r.binding)
    assert robot.p_base_ee_m[0] - start[0] > 0.05  # it kept moving along the human: sliding, not stopping

    blind = HumanAwareTeleop("panda")
    distances_off, _ = drive(blind, human, v, "off", 500)
    assert distances_off.min() < critical - 0.05  # the same command without the filter closes in


@pytest.mark.parametrize("method", ["stop", "reactive"])
def test_stop_and_reactive_never_cross_the_critical_distance(method):
    robot = HumanAwareTeleop("panda")
    human = human_beside(robot)
    distances, reports = drive(robot, human, np.array([0.0, 0.2, 0.0]), method, 500)
    assert distances.min() >= robot.arm.human.critical_m - 1e-6
    if method == "reactive":  # the field held it, not its stop at d_cr (nor the safety net alone)
        assert not any(r.stopped for r in reports)


def test_reactive_respects_the_protection_zones_it_does_not_know():
    robot = HumanAwareTeleop("panda", zones=[])
    p = robot.p_base_ee_m
    box = BoxZone("box", (p[0], p[1] + 0.3, p[2]), (0.1, 0.05, 0.08))
    robot.zones = [box]
    human = human_beside(robot, offset=(0.0, 1.5, 0.0))  # far: only the zone matters
    zone = next(c for c in robot.constraints if getattr(c, "zone", None) is box)
    assert zone.distances(robot.state).min() > 0.05  # clear at the start
    worst, pushed = np.inf, False
    for _ in range(400):
        robot.set_human(human)
        report = robot.step(np.array([0.0, 0.2, 0.0]), DT, "reactive")
        pushed |= any(name.startswith("box") for name in report.binding)
        worst = min(worst, float(zone.distances(robot.state).min()))
    assert worst >= -1e-6
    assert worst < robot.teleop.params.reactive_zone_m  # it came within the spring's reach
    assert pushed  # and the spring pushed back (not only the safety net)


def test_ssm_slows_the_approach_to_the_human():
    v = np.array([0.0, 0.25, 0.0])
    speeds = {}
    for ssm in (False, True):
        robot = HumanAwareTeleop("panda", ssm=ssm)
        human = human_beside(robot, offset=(0.0, 0.7, 0.0))
        _, reports = drive(robot, human, v, "anticipative", 60)
        speeds[ssm] = float(np.linalg.norm(reports[-1].v_executed_m_s))
    assert speeds[True] < 0.8 * speeds[False]


def test_a_dropout_keeps_the_last_human_and_a_fresh_empty_frame_clears_it():
    robot = HumanAwareTeleop("panda")
    human = human_beside(robot)
    robot.set_human(human)
    robot.set_human(HumanCapsules.absent(t_s=0.1, stale=True, reason="laser silent"))
    assert robot.step(np.zeros(3), DT).min_distance_m == pytest.approx(separation(robot, human), abs=1e-9)
    robot.set_human(HumanCapsules.absent(t_s=0.2))
    assert robot.step(np.zeros(3), DT).min_distance_m is None


def test_nan_command_holds_still():
    robot = HumanAwareTeleop("panda")
    robot.set_human(human_beside(robot))
    before = robot.p_base_ee_m
    for method in ("anticipative", "stop", "reactive", "off"):
        report = robot.step(np.array([np.nan, 0.1, 0.0]), DT, method)
        assert np.all(np.isfinite(report.p_base_ee_m))
    assert np.linalg.norm(robot.p_base_ee_m - before) < 0.01


def test_a_fast_human_never_makes_the_hand_flee_faster_than_the_speed_limit():
    """Retreat rows of capsules near the base once asked the hand for ~2 m/s; the per-axis
    speed rows cap it at ``max_speed_m_s`` per axis (the step approaches nothing instead)."""
    robot = HumanAwareTeleop("panda")
    limit = robot.teleop.params.max_speed_m_s
    start = robot.state.capsule_p1[2] - np.array([0.0, 0.9, 0.0])  # beside the upper arm
    fastest = 0.0
    for i in range(300):
        p = start + np.array([0.0, 1.5, 0.0]) * min(i * DT, 0.5)  # 1.5 m/s at the arm (2.2 m/s flight before)
        robot.set_human(HumanCapsules([p + [0, 0, -0.4]], [p + [0, 0, 0.4]], [0.15], ("torso",), t_s=i * DT))
        report = robot.step(np.zeros(3), DT, "anticipative")
        fastest = max(fastest, float(np.abs(report.v_executed_m_s).max()))
    assert fastest <= limit * 1.05  # first-order motion over a step: a few % of curvature
