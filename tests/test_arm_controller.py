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
import pytest

from cobotsafety.arm.controller import MAX_PERIOD_S, MAX_STEP_S, ArmController, StepError
from cobotsafety.arm.limitations import HalfSpaceZone, SphereZone
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


def random_teleoperation(robot: str, seed: int, method: str = "anticipative"):
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
        reports.append(controller.step(v, TELEOP_DT_S, method))
        assert np.all(np.isfinite(controller.state.q)), (robot, i)
        after = oracle_distances(controller)
        worst = max(worst, float(np.max(np.minimum(before, 0.0) - after)))
        nearest = min(nearest, float(after.min()))
        before = after
        q_path.append(controller.state.q.copy())
        p_path.append(controller.p_base_ee_m)
    return controller, reports, np.array(q_path), np.array(p_path), worst, nearest


SEED = 6
"""The commands' seed: without the filter (``off``) they cross a limitation on every robot."""


@lru_cache(maxsize=None)
def teleoperation_run(robot: str, method: str = "anticipative"):
    """One seeded run per robot and method, shared by the tests below."""
    return random_teleoperation(robot, SEED, method)


def ratios_of(robot: str):
    controller, _, q_path, p_path, _, _ = teleoperation_run(robot)
    model = controller.model
    ratios = motion_ratios(q_path, TELEOP_DT_S, model.limits, model.difference, p_path)
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
    unfiltered_worst = teleoperation_run(robot, "off")[4]
    assert unfiltered_worst > 1e-4, f"{robot}: the same commands without the filter cross nothing"  # exercised
    # The safety net (the step's bisection) is a backstop: the filter keeps the limits itself.
    assert sum(r.extras["net_scale"] < 1.0 for r in reports) <= 0.01 * len(reports)


XARM7_CAP = ("xarm7 (seed 6, dt 2 ms): the executed hand reaches 0.521 m/s against the 0.5 m/s cap (1.03x "
             "allowed) and 122 m/s^3 against the robot's 100, no step giving up smoothness. The cap is a plan "
             "row and gives way by least squares when it contradicts the joints' motion box and the demo's sphere "
             "zone's safety row; the kernel bounds J qddot's jerk, not the curvature's (dJ/dt qdot). Before the "
             "cap's lead on the hand's acceleration (joint_filter.filter_rows) the hand reached 0.669 m/s")


def _xfail(reason: str):
    return pytest.mark.xfail(strict=True, reason=reason)


JOINT_XFAIL: dict[str, str] = {}  # (kinova's slide on the sphere zone: fixed by the links' drift, 2026-12-03)


@pytest.mark.parametrize("robot", [pytest.param(r, marks=_xfail(JOINT_XFAIL[r])) if r in JOINT_XFAIL else r
                                   for r in ROBOT_NAMES])
def test_random_teleoperation_keeps_the_joint_motion_limits(robot):
    ratios, _, controller, words = ratios_of(robot)
    assert ratios.max_joint_velocity_ratio <= OVER_LIMIT_RATIO, words
    assert ratios.max_joint_acceleration_ratio <= OVER_LIMIT_RATIO, words
    assert ratios.max_joint_jerk_ratio <= OVER_LIMIT_RATIO, words
    assert controller.smoothness_steps == 0, words


EE_XFAIL = {
    "z1": ("z1 (seed 6, dt 2 ms): the commanded hand speed reaches 0.542 m/s at step 923 against the 0.5 m/s cap "
           "('speed' binding, no smoothness given up), and the executed hand acceleration 2.096 m/s^2 and jerk "
           "41.2 m/s^3 exceed the robot's 2.0 and 40 (with seed 3: 2.156 m/s^2, also at dt 1 and 4 ms; iiwa "
           "2.180): the kernel limits J qddot to EE_MOTION_SHARE (0.9) of the limit, the rest (dJ/dt qdot) "
           "needs more than the 10 % left for it"),
    "xarm7": XARM7_CAP}


@pytest.mark.parametrize("robot", [pytest.param(r, marks=_xfail(EE_XFAIL[r])) if r in EE_XFAIL else r
                                   for r in ROBOT_NAMES])
def test_random_teleoperation_keeps_the_hand_within_its_limits_and_the_cap(robot):
    ratios, limits, controller, words = ratios_of(robot)
    cap = min(controller.settings.max_speed_m_s, limits.ee_speed_m_s)
    assert ratios.max_ee_speed_m_s <= cap * 1.03, words  # executed: a few % of curvature over a step
    assert ratios.max_ee_acceleration_m_s2 <= limits.ee_acceleration_m_s2 * OVER_LIMIT_RATIO, words
    assert ratios.max_ee_jerk_m_s3 <= limits.ee_jerk_m_s3 * OVER_LIMIT_RATIO, words


def test_a_drag_past_the_speed_cap_arrives_at_the_cap_with_its_acceleration_ramped_down():
    """The hand dragged from rest at twice the cap in free space: its commanded speed levels off
    at the cap. On the xarm7 (the hand may accelerate at 50 m/s^2 but change that by only
    100 m/s^3) a hand still accelerating at the cap cannot stop there within the jerk limit:
    without the cap's ramp the cap gave way and the command reached 0.98 m/s against 0.5."""
    for robot in ("xarm7", "panda"):
        controller = ArmController(robot, zones=[])
        limits = controller.model.limits
        cap = min(controller.settings.max_speed_m_s, limits.ee_speed_m_s)
        v = np.array([0.0, -1.0, 0.2])
        v *= 2.0 * cap / np.linalg.norm(v)
        qs, ps, commanded = [controller.state.q.copy()], [controller.state.p_world_ee.copy()], []
        for _ in range(150):
            report = controller.step(v, 0.002)
            qs.append(controller.state.q.copy())
            ps.append(controller.state.p_world_ee.copy())
            commanded.append(float(np.linalg.norm(report.v_commanded_m_s)))
        assert max(commanded) >= 0.95 * cap, robot  # it got there
        assert max(commanded) <= 1.01 * cap, robot
        model = controller.model
        ratios = motion_ratios(np.array(qs), 0.002, limits, model.difference, np.array(ps))
        assert ratios.max_ee_jerk_m_s3 <= limits.ee_jerk_m_s3 and controller.smoothness_steps == 0, robot


@pytest.mark.parametrize("robot", ["xarm7", "panda"])
def test_a_hand_turning_at_the_cap_stays_at_the_cap(robot):
    """Commands above the cap that turn by 90 or 180 degrees every 0.15 s (1 ms steps): the
    hand's commanded speed stays at the cap. A turning hand accelerates across its velocity;
    on the xarm7 (50 m/s^2 but only 100 m/s^3) an acceleration built up while the speed was
    below the cap can only be shed beyond it: with the cap applied to the speed alone the
    hand reached 0.94 m/s against 0.5 (``joint_filter.filter_rows``'s ``lead``)."""
    controller = ArmController(robot, zones=[])
    cap = min(controller.settings.max_speed_m_s, controller.model.limits.ee_speed_m_s)
    turns = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    commanded = []
    for i in range(3600):
        report = controller.step(0.8 * turns[(i // 150) % len(turns)], 0.001)
        commanded.append(float(np.linalg.norm(report.v_commanded_m_s)))
    assert max(commanded) >= 0.95 * cap  # it got there
    assert max(commanded) <= 1.01 * cap
    assert controller.smoothness_steps == 0


# ---- limitations one by one ----------------------------------------------------------------------
def test_recovery_from_inside_a_zone_only_reduces_the_violation():
    """The hand starts inside a sphere zone; whatever it is commanded (random, seeded), the
    deepest penetration never deepens, and the arm drifts out."""
    controller = ArmController("panda", zones=[])
    p = controller.p_base_ee_m
    controller.zones = [SphereZone("blob", tuple(p + np.array([0.0, 0.0, 0.05])), 0.08)]  # over the hand
    zone_rows = len(controller.model.capsules) - 1  # the zone's distances: the last ones, one per capsule

    def depth() -> float:
        return float(oracle_distances(controller)[-zone_rows:].min())

    rng = np.random.default_rng(5)
    start = previous = depth()
    assert start < -0.05
    for i in range(400):
        if i % 40 == 0:
            v = rng.normal(size=3) * 0.3
        controller.step(v, 0.002)
        d = depth()
        assert d >= previous - CROSSING_M, (i, d, previous)
        previous = d
    assert previous > start + 0.02


def test_zones_added_replaced_or_removed_in_place_take_effect_at_the_next_step():
    """A wall just below the hand, added to the zones list in place, stops a downward drag; the
    same wall replaced in place by one far below frees it; removed, the drag is free too."""
    controller = ArmController("panda", zones=[], table=False)
    z = controller.p_base_ee_m[2]
    down = [0.0, 0.0, -0.2]

    def dropped() -> float:
        start = controller.p_base_ee_m[2]
        drive(controller, down, 50, 0.002)
        return start - controller.p_base_ee_m[2]

    free = dropped()
    assert free > 0.01
    controller.zones.append(HalfSpaceZone("floor", (0.0, 0.0, z - free - 0.002), (0.0, 0.0, -1.0)))
    assert dropped() < 0.002 and "floor" in " ".join(controller.last_report.binding)
    controller.zones[0] = HalfSpaceZone("floor", (0.0, 0.0, -1.0), (0.0, 0.0, -1.0))
    assert dropped() > 0.5 * free
    controller.zones.pop()
    assert dropped() > 0.5 * free


def test_a_singular_pose_gives_finite_commands_and_the_arm_bends_away():
    controller = ArmController("ur5", zones=[], reach=False, table=False)  # the singularity alone
    controller.set_configuration(np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]))  # stretched up: singular
    z0 = controller.p_base_ee_m[2]
    up = drive(controller, [0.0, 0.0, 0.3], 20, 0.002)  # stretching further: nothing to give
    assert all(np.all(np.isfinite(r.v_commanded_m_s)) for r in up)
    assert controller.p_base_ee_m[2] <= z0 + 1e-4
    side = drive(controller, [0.3, 0.0, 0.0], 100, 0.002)  # sideways: the arm can still move
    assert np.linalg.norm(side[-1].v_executed_m_s) > 0.1
    down = drive(controller, [0.0, 0.0, -0.3], 300, 0.002)  # back along the singular direction
    assert all(np.all(np.isfinite(r.v_commanded_m_s)) and np.all(np.isfinite(r.p_base_ee_m)) for r in down)
    assert controller.p_base_ee_m[2] < z0 - 0.02


@pytest.mark.parametrize("method", ["anticipative", "stop", "reactive", "off"])
def test_a_non_finite_command_or_period_never_reaches_the_state(method, caplog):
    controller = ArmController("panda")
    drive(controller, [0.2, 0.1, 0.0], 50, 0.002, method)  # moving
    with caplog.at_level(logging.WARNING, logger="cobotsafety.arm.controller"):
        for dt in (np.nan, np.inf, -0.002, 0.0):  # a bad period: nothing integrated
            q = controller.state.q.copy()
            report = controller.step(np.array([0.2, 0.1, 0.0]), dt, method)
            np.testing.assert_array_equal(controller.state.q, q)
            assert report.stopped and "refused" in report.reason
            np.testing.assert_array_equal(report.v_commanded_m_s, np.zeros(3))
        for v in ([np.nan, 0.1, 0.0], [np.inf, 0.0, 0.0], [0.0, -np.inf, np.nan]):  # a bad command: zero
            report = controller.step(np.array(v), 0.002, method)
            assert "not finite" in report.reason
            assert np.all(np.isfinite(controller.state.q)) and np.all(np.isfinite(report.v_commanded_m_s))
    assert len([r for r in caplog.records if r.levelno == logging.WARNING]) == 7  # one line each
    twin = ArmController("panda")  # a non-finite command is the zero command, step for step
    twin.set_configuration(controller.state.q)
    still = ArmController("panda")
    still.set_configuration(controller.state.q)
    for _ in range(20):
        twin.step(np.array([np.nan, 0.0, 0.0]), 0.002, method)
        still.step(np.zeros(3), 0.002, method)
    np.testing.assert_array_equal(twin.state.q, still.state.q)
    with pytest.raises(ValueError, match="shape"):
        controller.step(np.zeros(2), 0.002, method)


def test_a_long_period_is_split_and_a_jump_refused():
    a, b = ArmController("panda"), ArmController("panda")
    v = np.array([0.2, -0.1, 0.05])
    for _ in range(5):
        a.step(v, 0.025)  # three steps of 1/120 s each
        for _ in range(3):
            b.step(v, 0.025 / 3)
    np.testing.assert_allclose(a.state.q, b.state.q, atol=1e-12)
    assert 0.025 / 3 <= MAX_STEP_S
    with pytest.raises(StepError):
        a.step(v, 2 * MAX_PERIOD_S)


def test_the_extended_reach_holds_while_the_arm_stretches():
    controller = ArmController("panda", zones=[])
    shoulder, outer = np.array(controller.reach.shoulder), controller.reach.outer_m
    for _ in range(1500):  # drag straight out for 3 s
        controller.step(np.array([0.5, 0.0, 0.2]), 0.002)
        assert np.linalg.norm(Kinematics(controller.model, controller.state.q).p_ee - shoulder) <= outer + CROSSING_M
    assert np.linalg.norm(controller.p_base_ee_m - shoulder) > outer - 0.01  # it got there and slid on it
    assert "reach extended" in controller.last_report.binding


def test_two_walls_make_the_hand_slide_along_their_edge():
    probe = ArmController("panda", zones=[])
    p = probe.p_base_ee_m
    walls = [HalfSpaceZone("floor", (0.0, 0.0, p[2] - 0.1), (0.0, 0.0, -1.0), skip_capsules=6),
             HalfSpaceZone("wall", (p[0] + 0.1, 0.0, 0.0), (1.0, 0.0, 0.0), skip_capsules=6)]
    controller = ArmController("panda", zones=walls)
    drive(controller, [0.3, 0.0, -0.3], 500, 0.002)  # into the corner
    reports = drive(controller, [0.3, 0.2, -0.3], 100, 0.002)
    assert {"floor", "wall"} <= {name.split(" ")[0] for name in reports[-1].binding}
    executed = reports[-1].v_executed_m_s
    assert executed[1] > 0.1 and abs(executed[0]) < 0.01 and abs(executed[2]) < 0.01  # along the edge (y)
    assert np.all(oracle_distances(controller) >= -CROSSING_M)


def test_free_space_commands_are_followed_up_to_the_speed_cap_a_norm():
    speeds = {}
    for direction in ((-1.0, 0.0, 0.0), (-1.0, -1.0, 1.0)):  # inward: no limitation on the way
        controller = ArmController("panda", zones=[])
        u = np.array(direction) / np.linalg.norm(direction)
        slow = drive(controller, 0.1 * u, 300, 0.002)  # below the cap: followed exactly
        np.testing.assert_allclose(slow[-1].v_commanded_m_s, 0.1 * u, atol=1e-9)
        assert slow[-1].binding == ()
        fast = drive(controller, 2.0 * u, 100, 0.002)  # four times the cap: capped, along the command
        assert set(fast[-1].binding) <= {"speed"}
        speeds[direction] = np.linalg.norm(fast[-1].v_commanded_m_s)
        np.testing.assert_allclose(fast[-1].v_commanded_m_s / speeds[direction], u, atol=1e-6)
    cap = controller.settings.max_speed_m_s
    # At the cap: the hand's acceleration ramps down toward it (jerk-limited) and levels off a
    # little under it (half the speed its curving path loses per step at a constant joint
    # velocity); never over it, a diagonal no faster.
    for speed in speeds.values():
        assert cap * (1.0 - 1e-3) <= speed <= cap * (1.0 + 1e-9)


def test_joint_limits_hold_when_the_arm_is_driven_into_them():
    controller = ArmController("panda", zones=[], reach=False, table=False)  # the joints alone
    model = controller.model
    iq = model.limited[:, 0]
    met = set()
    for v in ([0.0, 0.0, 0.5], [-0.5, 0.0, -0.3], [0.0, 0.5, 0.0]):
        for _ in range(600):
            report = controller.step(np.array(v), 0.004)
            q = controller.state.q
            assert np.all(q[iq] >= model.lower[iq] - CROSSING_M) and np.all(q[iq] <= model.upper[iq] + CROSSING_M)
            met |= {name for name in report.binding if name.endswith((" lower", " upper"))}
    assert met, "no joint limit was met"


def test_the_reported_joint_acceleration_ratio_is_the_steps_own():
    """``ArmStepReport.joint_acceleration_ratio`` (the demo's acceleration chart) equals the
    largest |second difference of q| / dt^2 / limit of the same step, measured from the states."""
    controller = ArmController("panda")
    dt = 1e-3
    limits = controller.model.limits.acceleration_rad_s2
    q = [controller.state.q.copy(), controller.state.q.copy()]  # at rest before the first step
    ratios = []
    for k in range(300):
        report = controller.step(np.array([0.2, -0.1, 0.05]) if k < 150 else np.zeros(3), dt)
        q.append(controller.state.q.copy())
        measured = np.max(np.abs(q[-1] - 2 * q[-2] + q[-3]) / dt ** 2 / limits)
        assert report.joint_acceleration_ratio == pytest.approx(measured, rel=1e-6, abs=1e-9)
        ratios.append(report.joint_acceleration_ratio)
    assert 0.1 < max(ratios) <= 1.0 + 1e-9


def test_a_step_only_the_safety_net_scaled_is_counted_and_given_a_reason(monkeypatch):
    """Item 4 of issue 20 (never silent): a step whose filter kept every row (level 0) but whose
    integration the safety net scaled down gives up smoothness: it is counted and says why. The net
    acts on no step of the suite's runs, so the kernel's output is forced here: the real step, then
    its net scale set to 0.5 and its smoothness flag raised, as the kernel writes them."""
    import cobotsafety.arm.controller as controller_module
    from cobotsafety.arm.step_kernel import GAVE_WAY_NET, I_LEVEL, I_SMOOTHNESS

    real_step, offsets = controller_module.arm_step, []

    def net_scaled(*args):
        status = real_step(*args)
        out_f, out_i = args[-2], args[-1]
        out_f[offsets[0][12]], out_i[I_SMOOTHNESS] = 0.5, GAVE_WAY_NET
        assert out_i[I_LEVEL] == 0  # the filter itself kept every row
        return status

    controller = ArmController("panda")
    offsets.append(controller._offsets)
    controller.step(np.array([0.1, 0.0, 0.0]), 1e-3)
    assert controller.smoothness_steps == 0 and controller.last_report.reason == ""
    monkeypatch.setattr(controller_module, "arm_step", net_scaled)
    report = controller.step(np.array([0.1, 0.0, 0.0]), 1e-3)
    assert report.safety_over_smoothness and controller.smoothness_steps == 1
    assert report.extras["net_scale"] == 0.5
    assert report.reason == "safety over smoothness: the safety net executed 0.5 of the step to keep a limitation"


def test_the_human_buffers_packing_is_ready_before_the_first_person():
    """``set_human`` packs a person with compiled code (``limitations.human.human_buffer``): a new
    controller has it compiled (or loaded from the cache) already, so the control thread does not
    stop to compile when the first person is seen. A fresh process, so no other test has called it."""
    import subprocess
    import sys

    code = ("from cobotsafety.arm.controller import ArmController\n"
            "from cobotsafety.arm.limitations.human import human_buffer\n"
            "before = len(human_buffer.overloads)\n"
            "ArmController('panda')\n"
            "print(before, len(human_buffer.overloads))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=True)
    before, after = map(int, out.stdout.split())
    assert before == 0 and after >= 1
