"""The posture move home of a task stalled at joint limits (``control/recovery.py``) and the
joint-space command it drives (``ArmController.step_joints``)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cobotsafety.arm.controller import ArmController
from cobotsafety.control.nominal_path import NominalPath
from cobotsafety.control.recovery import PostureRecovery
from test_arm_controller import CROSSING_M, oracle_distances

DT_S = 0.002
#: The panda's posture of campaign person 250 (seed 0) at its deadlock (docs/campaign.md):
#: joints 1, 3 and 7 at their lower limits.
WOUND_Q = np.array([-2.896, -0.126, -2.896, -2.316, -1.552, 1.086, -2.896])


def test_a_joint_command_in_free_space_is_followed_within_the_motion_limits():
    controller = ArmController("panda", zones=[], reach=False, table=False)
    command = np.zeros(controller.model.nv)
    command[3], command[5] = 0.2, -0.1  # the elbow and the wrist, away from their limits
    reports = [controller.step_joints(command, DT_S) for _ in range(500)]
    np.testing.assert_allclose(reports[-1].extras["qdot"], command, atol=1e-9)  # reached and held
    assert max(r.joint_acceleration_ratio for r in reports) <= 1.0 + 1e-9  # ramped up within the limit
    assert not any(r.safety_over_smoothness for r in reports)
    np.testing.assert_allclose(reports[-1].v_desired_m_s, controller.state.J_ee @ command, atol=1e-3)


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_a_joint_command_never_crosses_a_joint_limit_a_zone_or_the_table(robot):
    controller = ArmController(robot)  # the demo's cell: joint limits, reach, table, three zones
    speed = 0.5 * controller.model.limits.velocity_rad_s
    rng = np.random.default_rng(7)
    met = set()
    for _ in range(4):
        command = speed * rng.choice([-1.0, 1.0], size=speed.shape)  # every joint at half its speed
        for _ in range(400):
            report = controller.step_joints(command, 0.004)
            assert np.all(oracle_distances(controller) >= -CROSSING_M)
            met |= set(report.binding)
    assert any(name.endswith((" lower", " upper")) for name in met), met  # it met some


def test_a_non_finite_joint_command_is_the_zero_command_and_a_wrong_shape_is_refused(caplog):
    controller = ArmController("panda", zones=[])
    still = ArmController("panda", zones=[])
    command = np.full(controller.model.nv, 0.1)
    for _ in range(50):
        controller.step_joints(command, DT_S)
    still.set_configuration(controller.state.q)
    with caplog.at_level(logging.WARNING, logger="cobotsafety.arm.controller"):
        report = controller.step_joints(np.full(controller.model.nv, np.nan), DT_S)
    assert "not finite" in report.reason and len(caplog.records) == 1
    assert np.all(np.isfinite(controller.state.q)) and np.all(np.isfinite(report.v_desired_m_s))
    twin = ArmController("panda", zones=[])
    twin.set_configuration(controller.state.q)
    still.set_configuration(controller.state.q)
    for _ in range(20):
        twin.step_joints(np.array([np.inf] + [0.0] * 6), DT_S)
        still.step_joints(np.zeros(7), DT_S)
    np.testing.assert_array_equal(twin.state.q, still.state.q)
    with pytest.raises(ValueError, match="shape"):
        controller.step_joints(np.zeros(3), DT_S)


def _recovery() -> PostureRecovery:
    return PostureRecovery(np.zeros(3), np.array([2.0, 2.0, 4.0]))


HAND = np.array([0.5, 0.0, 0.4])
TARGET = HAND + [0.3, 0.0, 0.0]


def test_the_recovery_starts_only_after_the_hand_came_no_closer_at_joint_limits_for_stall_s():
    q = np.array([1.0, -0.5, 0.2])
    recovery = _recovery()
    steps = int(2 * recovery.stall_s / DT_S)
    t0 = 0.0
    for k in range(steps):  # not blocked by a joint limit (e.g. a person in the way): waits
        assert recovery.command(t0 + k * DT_S, q, HAND, TARGET, blocked=False) is None
    t0 += steps * DT_S
    for k in range(steps):  # blocked, crawling toward the target at 10 mm/s: making its way
        assert recovery.command(t0 + k * DT_S, q, HAND + [0.01 * k * DT_S, 0.0, 0.0], TARGET, blocked=True) is None
    t0 += steps * DT_S
    for k in range(steps):  # blocked, trailing a target that moves at the path's lag: making its way
        moved = [0.0, 0.12 * k * DT_S, 0.0]
        assert recovery.command(t0 + k * DT_S, q, HAND + moved, TARGET + moved, blocked=True) is None
    t0 += steps * DT_S
    for k in range(steps):  # blocked and still, but the target within reach: waits
        assert recovery.command(t0 + k * DT_S, q, HAND, HAND + [0.9 * recovery.near_m, 0, 0], blocked=True) is None
    t0 += steps * DT_S
    for k in range(steps):  # blocked and still, the limit letting go every half stall: waits
        blocked = (k + 1) % int(0.5 * recovery.stall_s / DT_S) != 0
        assert recovery.command(t0 + k * DT_S, q, HAND, TARGET, blocked=blocked) is None
    t0 += steps * DT_S
    started = None
    for k in range(steps):  # blocked, circling 3 cm wide short of the target: after stall_s, toward home
        loop = 0.015 * np.array([np.cos(2 * np.pi * k * DT_S), np.sin(2 * np.pi * k * DT_S), 0.0])
        out = recovery.command(t0 + k * DT_S, q, HAND + loop, TARGET, blocked=True)
        if out is not None:
            started = k * DT_S
            break
    assert started == pytest.approx(recovery.stall_s, abs=1.5 * DT_S) and recovery.count == 1
    assert np.all(np.sign(out) == np.sign(-q))  # toward home
    assert np.max(np.abs(out) / recovery.velocity_limit_rad_s) <= recovery.speed_share + 1e-12


def _stall(recovery: PostureRecovery, q: np.ndarray) -> tuple[float, int]:
    t, k = 0.0, 0
    while recovery.command(t, q, HAND, TARGET, blocked=True) is None:
        k += 1
        t = k * DT_S
    return t, k


def test_the_recovery_ends_at_home_or_when_its_own_move_is_stuck():
    recovery = _recovery()
    q = np.array([1.0, -0.5, 0.2])
    t, k = _stall(recovery, q)
    moving = q.copy()
    for _ in range(int(60.0 / DT_S)):  # (bounded: a recovery that never ends fails, not hangs)
        if (out := recovery.command(t, moving, HAND, TARGET, blocked=True)) is None:  # followed exactly
            break
        moving = moving + out * DT_S
        k += 1
        t = k * DT_S
    assert np.max(np.abs(moving)) <= recovery.home_rad and not recovery.recovering
    assert recovery.command(t + DT_S, moving, HAND, TARGET, blocked=True) is None  # the task resumes
    stuck = _recovery()
    t, k = _stall(stuck, q)
    start = t
    for _ in range(int(10 * stuck.stall_s / DT_S)):
        if stuck.command(t, q, HAND, TARGET, blocked=True) is None:  # the posture never moves: given up
            break
        k += 1
        t = k * DT_S
    assert t - start == pytest.approx(stuck.stall_s, abs=1.5 * DT_S) and not stuck.recovering


@pytest.mark.parametrize("with_recovery", [True, False])
def test_a_task_wound_into_joint_limits_completes_through_the_move_home(with_recovery, monkeypatch):
    """From the panda's wound posture the closest feasible hand velocity toward the target is
    zero: without the recovery the task never finishes; with it, it does, every limitation kept."""
    from cobotsafety.experiments import approach_step
    from cobotsafety.experiments.human_approach import run_episode
    from cobotsafety.human.body import BodyDimensions
    from cobotsafety.tools.campaign.person_run import _Nobody

    if not with_recovery:
        monkeypatch.setattr(PostureRecovery, "command", lambda self, *args: None)
    controller = approach_step.make_controller("panda", "anticipative")
    controller.arm.set_configuration(WOUND_Q)
    p = approach_step.state(controller).p_world_ee.copy()
    goal = p + np.array([0.12, -0.276, 0.006])  # the stalled run's command, 0.3 m along it
    log = run_episode(controller, _Nobody(), BodyDimensions(), NominalPath(np.array([p, goal]), speed_m_s=0.12),
                      DT_S, 20.0)
    q = np.array(log.q_rad)
    limits = controller.arm.model
    assert np.all(q >= limits.lower - CROSSING_M) and np.all(q <= limits.upper + CROSSING_M)
    if with_recovery:
        assert log.completion_s is not None and log.posture_recoveries == 1
    else:
        assert log.completion_s is None
        assert np.linalg.norm(controller.arm.state.p_world_ee - p) < 0.02  # held still for 20 s


def test_the_move_home_of_an_arm_with_continuous_joints_goes_the_joint_way_home():
    """The JACO2 (``kinova``) stores its continuous joints as cos / sin (nq = 9, nv = 6): the move
    home is ``pin.difference`` from the joints now to home, the same motion a revolute arm's
    subtraction gives; without a difference such an arm is refused in one line. Before,
    ``experiment human-approach --robot kinova`` (and the campaign) stopped on that refusal."""
    import pinocchio as pin

    model = ArmController("kinova").model
    home, limits = model.home_q, model.limits.velocity_rad_s
    with pytest.raises(ValueError, match="needs a difference"):
        PostureRecovery(home, limits)
    recovery = PostureRecovery(home, limits, difference=model.difference)
    away = np.array([0.3, -0.2, 0.25, -3.0, 0.1, 3.0])  # joints 1, 4, 6 continuous: 3 rad, not 2 pi - 3
    q = pin.integrate(model.model, home, away)
    recovery.recovering = True
    ratio = np.max(np.abs(away) / (recovery.speed_share * limits))  # > 1: scaled to half the speed limits
    np.testing.assert_allclose(recovery.command(0.0, q, HAND, TARGET, blocked=True), -away / ratio, atol=1e-12)


def test_paper_2s_experiment_runs_on_the_arm_with_continuous_joints():
    from cobotsafety.experiments.human_approach import run_approach

    run = run_approach("anticipative", scenario="exp1", robot="kinova", duration_s=0.5)
    q = run.log.commanded_path()[0]
    assert q.shape[1] == 9 and len(q) > 0.5 * 275 and np.all(np.isfinite(q))
