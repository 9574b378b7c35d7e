"""The 3D step's smoothness rules: bounded acceleration (limitations win), relaxed retreats,
the null-space term's tolerance, and the once-per-episode contradiction warning."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.constraints import ArmConstraint, Measures
from cobotsafety.arm.step import ArmParams, secondary_scale, step
from cobotsafety.arm.teleop import ArmTeleop

DT = 0.004


@dataclass
class HandRows(ArmConstraint):
    """Test limitation on the hand: rows ``normal . p_ee`` with fixed distances and rates (a
    limit moving by itself at ``rate``); its distances do not change with q."""

    normals: np.ndarray
    distance_m: np.ndarray
    rate_m_s: np.ndarray
    name: str = "hand rows"

    def measures(self, state, activation_m=np.inf):
        A = self.normals @ state.J_ee
        names = tuple(f"{self.name} {i}" for i in range(len(self.distance_m)))
        return Measures(self.distance_m.copy(), A, names, np.zeros(len(self.distance_m), dtype=bool), self.rate_m_s.copy())

    def distances(self, state):
        return self.distance_m.copy()


def test_a_rounding_level_null_space_approach_keeps_the_secondary_task():
    params = ArmParams()
    inside = Measures(np.array([0.5e-3]), np.array([[1.0, 0.0, 0.0]]), ("row",), np.zeros(1, dtype=bool))
    # a . c = -6.9e-18: an orthogonal pair up to rounding, not an approach (issue 12).
    assert secondary_scale(inside, np.array([-6.9e-18, 1.0, 0.0]), DT, params) == 1.0
    # A real approach inside the buffer still drops the secondary task.
    assert secondary_scale(inside, np.array([-1e-3, 1.0, 0.0]), DT, params) == 0.0


def test_the_command_changes_by_at_most_the_acceleration_bound_in_free_space():
    robot = ArmTeleop("panda", zones=[])
    a_dt = robot.params.max_accel_m_s2 * DT
    previous = np.zeros(3)
    commands, executed = [], []
    for i in range(240):
        v = np.array([0.4, 0.0, 0.0]) if (i // 60) % 2 == 0 else np.array([-0.4, 0.1, 0.0])
        report = robot.step(v, DT)
        assert report.binding == () or all(name.startswith("speed") for name in report.binding)
        assert np.all(np.abs(report.v_commanded_m_s - previous) <= a_dt + 1e-12)
        previous = report.v_commanded_m_s
        commands.append(previous)
        executed.append(report.v_executed_m_s)
    commands = np.array(commands)
    np.testing.assert_allclose(commands[59], [0.4, 0.0, 0.0], atol=1e-12)  # reached after 0.4 / 3 s
    jumps = np.linalg.norm(np.diff(np.array(executed), axis=0), axis=1)
    assert jumps.max() < 2.0 * np.sqrt(3) * a_dt  # the executed velocity follows (second order aside)


def test_without_a_previous_command_the_step_is_unchanged_by_the_bound():
    a, b = ArmTeleop("panda", zones=[]), ArmTeleop("panda", zones=[])
    v = np.array([0.3, -0.2, 0.1])
    info_a = step(a.state, v, DT, a.constraints, a.params, "anticipative", a.R_world_ee_ref)
    info_b = step(b.state, v, DT, b.constraints, ArmParams(max_accel_m_s2=np.inf), "anticipative", b.R_world_ee_ref,
                  v_previous=np.zeros(3))
    np.testing.assert_allclose(info_a.v_commanded, v, atol=1e-12)
    np.testing.assert_allclose(info_b.v_commanded, v, atol=1e-12)


def test_a_required_retreat_wins_over_the_acceleration_bound():
    # A limit 5 mm inside its buffer, closing on the hand along +y at 0.4 m/s: the hand must
    # retreat along -y at least that fast now, from rest.
    rows = HandRows(np.array([[0.0, -1.0, 0.0]]), np.array([-0.004]), np.array([-0.4]))
    robot = ArmTeleop("panda", zones=[], extra_constraints=[rows])
    info = step(robot.state, np.zeros(3), DT, robot.constraints, robot.params, "anticipative", robot.R_world_ee_ref,
                v_previous=np.zeros(3))
    hs = info.halfspaces
    assert np.all(hs.normals @ info.v_commanded >= hs.bounds - 1e-9)  # every limitation holds
    assert -info.v_commanded[1] >= 0.4  # a jump far above a dt = 0.012 m/s: safety wins
    assert not info.relaxed and not info.stopped


def test_contradicting_retreats_are_relaxed_and_the_arm_still_moves_away():
    # Two limits closing on the hand from directions whose retreats no speed-capped command
    # meets at once: the old step approached nothing (a stop); the relaxation moves away.
    normals = np.array([[0.0, 1.0, 0.0], [0.6, -0.8, 0.0]])
    rows = HandRows(normals, np.array([-0.002, -0.002]), np.array([-0.45, -0.3]))
    robot = ArmTeleop("panda", zones=[], extra_constraints=[rows])
    info = step(robot.state, np.zeros(3), DT, robot.constraints, robot.params, "anticipative", robot.R_world_ee_ref,
                v_previous=np.zeros(3))
    assert info.relaxed and not info.stopped
    assert info.reason.startswith("retreats contradict")
    rates = normals @ info.v_commanded
    assert np.all(rates >= -1e-9) and rates.sum() > 0.1  # away from both, as far as it can


def test_the_contradiction_warning_comes_once_per_episode_with_a_count(caplog):
    normals = np.array([[0.0, 1.0, 0.0], [0.6, -0.8, 0.0]])
    rows = HandRows(normals, np.array([-0.002, -0.002]), np.array([-0.45, -0.3]))
    robot = ArmTeleop("panda", zones=[], extra_constraints=[rows])
    with caplog.at_level(logging.WARNING):
        reports = [robot.step(np.zeros(3), DT) for _ in range(20)]
    warnings = [r for r in caplog.records if "contradict" in r.getMessage()]
    assert len(warnings) == 1
    assert [r.contradictions for r in reports] == list(range(1, 21))
    assert all(r.reason.startswith("retreats contradict") for r in reports)
    robot.reset()
    assert robot.step(np.zeros(3), DT).contradictions == 1  # a new episode counts afresh
    assert len([r for r in caplog.records if "contradict" in r.getMessage()]) == 2


def test_the_human_aware_arm_yields_for_a_dwell_instead_of_stopping_and_going():
    from cobotsafety.control.controllers import YIELD_DWELL_S, HumanAwareArm

    arm = HumanAwareArm("panda")
    # Opposite retreats along y: no motion along y meets either; the command asks for y only.
    rows = HandRows(np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]), np.array([-0.002, -0.002]), np.array([-0.3, -0.2]))
    arm.teleop.extra_constraints.append(rows)
    first = arm.step(np.array([0.0, 0.3, 0.0]), DT).report
    assert first.stopped and first.reason.startswith("yielding: retreats contradict")
    arm.teleop.extra_constraints.remove(rows)  # the contradiction is gone at once ...
    steps = int(round(YIELD_DWELL_S / DT))
    reports = [arm.step(np.array([0.0, 0.3, 0.0]), DT).report for _ in range(steps + 5)]
    assert all(r.stopped and r.reason.startswith("yielding") for r in reports[:steps - 1])  # ... it still yields
    assert not reports[-1].stopped and reports[-1].v_commanded_m_s[1] > 0.0  # then goes, once
