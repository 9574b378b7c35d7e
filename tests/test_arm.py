"""3D arms on pinocchio: loading, Jacobians and constraint normals vs finite differences,
capsules covering the links, the stepping invariant, recovery, singularities."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from cobotsafety.arm.robot_capsules import load_capsules
from cobotsafety.arm.constraints import JointPositionLimits, ReachLimits, TablePlane, ZoneConstraint
from cobotsafety.tools.fit_capsules import link_points
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.robots import ROBOTS, load_robot
from cobotsafety.arm.step import ArmParams, build_halfspaces, mapping, all_measures
from cobotsafety.arm.teleop import ArmTeleop
from cobotsafety.arm.zones import BoxZone, CapsuleZone, HalfSpaceZone, SphereZone
from cobotsafety.errors import UnknownRobotError
from cobotsafety import slide

ROBOT_NAMES = list(ROBOTS)


def random_q(state: RobotState, rng) -> np.ndarray:
    lower = np.where(np.isfinite(state.lower) & (state.lower > -10), state.lower, -np.pi)
    upper = np.where(np.isfinite(state.upper) & (state.upper < 10), state.upper, np.pi)
    return pin.randomConfiguration(state.model, lower, upper)


@pytest.fixture(scope="module", params=ROBOT_NAMES)
def state(request):
    return RobotState(request.param)


def test_every_robot_loads_by_name_and_unknown_names_list_the_known_ones():
    for name in ROBOT_NAMES:
        model, _, spec = load_robot(name)
        assert model.existFrame(spec.ee_frame)
        assert len(spec.home_q) == model.nq
    with pytest.raises(UnknownRobotError, match="panda.*ur5.*kinova.*z1.*xarm7.*iiwa"):
        load_robot("kr6")


def test_continuous_joint_robot_has_nq_different_from_nv():
    s = RobotState("kinova")
    assert (s.model.nq, s.model.nv) == (9, 6)
    robot = ArmTeleop("kinova")
    for _ in range(300):
        robot.step(np.array([0.1, 0.2, 0.0]), 0.01)
    q = robot.state.q
    for j in range(1, robot.state.model.njoints):
        joint = robot.state.model.joints[j]
        if joint.nq == 2:  # cos, sin of a continuous joint stay on the unit circle
            assert np.hypot(*q[joint.idx_q:joint.idx_q + 2]) == pytest.approx(1.0, abs=1e-9)


def test_jacobians_match_finite_differences(state):
    rng = np.random.default_rng(0)
    eps = 1e-6
    for _ in range(5):
        state.q = random_q(state, rng)
        state.update()
        J = state.J_ee.copy()
        k = len(state.capsules) - 1
        p = 0.5 * (state.capsule_p0[k] + state.capsule_p1[k])
        local = state.data.oMi[state.capsule_joint_ids[k]].actInv(p)
        Jp = state.point_jacobian(k, p)
        q0 = state.q.copy()
        for i in range(state.nv):
            dq = np.zeros(state.nv)
            dq[i] = eps
            out = []
            for sign in (1, -1):
                state.q = pin.integrate(state.model, q0, sign * dq)
                state.update()
                out.append((state.p_world_ee.copy(), state.data.oMi[state.capsule_joint_ids[k]].act(local)))
            np.testing.assert_allclose(J[:, i], (out[0][0] - out[1][0]) / (2 * eps), atol=1e-6)
            np.testing.assert_allclose(Jp[:, i], (out[0][1] - out[1][1]) / (2 * eps), atol=1e-6)
        state.q = q0
        state.update()


ZONES = [
    SphereZone("sphere", (0.3, 0.2, 0.4), 0.1),
    CapsuleZone("capsule", (0.2, -0.3, 0.2), (0.4, -0.1, 0.5), 0.05),
    BoxZone("box", (0.35, 0.0, 0.25), (0.1, 0.15, 0.08)),
    HalfSpaceZone("wall", (0.6, 0.0, 0.0), (1.0, 0.0, 0.0)),
]


def test_constraint_normals_match_finite_differences(state):
    """d(q + eps qdot) - d(q - eps qdot) over 2 eps equals a . qdot, for every measure."""
    rng = np.random.default_rng(1)
    eps = 1e-7
    constraints = [JointPositionLimits(), ReachLimits((0, 0, 0.3), 0.2, 0.8), TablePlane(0.0, skip_capsules=0)]
    constraints += [ZoneConstraint(z) for z in ZONES]
    checked = 0
    for _ in range(8):
        q0 = random_q(state, rng)
        state.q = q0
        state.update()
        for constraint in constraints:
            m = constraint.measures(state)
            qdot = rng.normal(size=state.nv)
            values = []
            for sign in (1, -1):
                state.q = pin.integrate(state.model, q0, sign * eps * qdot)
                state.update()
                values.append(constraint.measures(state).distance)
            state.q = q0
            state.update()
            if values[0].shape != m.distance.shape:
                continue
            fd = (values[0] - values[1]) / (2 * eps)
            # Skip kinks (the closest feature switches between +eps and -eps).
            smooth = np.abs(values[0] + values[1] - 2 * m.distance) < 1e-9
            np.testing.assert_allclose((m.A @ qdot)[smooth], fd[smooth], rtol=1e-4, atol=1e-5, err_msg=str(m.names))
            checked += int(smooth.sum())
    assert checked > 20


def test_capsules_cover_every_collision_vertex():
    for name in ("panda", "ur5", "kinova", "z1", "xarm7", "iiwa"):
        model, collision, _ = load_robot(name)
        capsules = {c.joint: c for c in load_capsules(name)}
        for joint, points in link_points(collision, model).items():
            c = capsules[joint]
            p0, p1 = np.array(c.p0_joint), np.array(c.p1_joint)
            seg = p1 - p0
            t = np.clip((points - p0) @ seg / max(seg @ seg, 1e-18), 0, 1)
            distance = np.linalg.norm(points - (p0 + t[:, None] * seg), axis=1)
            assert distance.max() <= c.radius_m + 1e-6, (name, joint)


def test_three_active_constraints_slide_along_an_edge_like_a_qp():
    probe = RobotState("panda")
    p = probe.p_world_ee
    zones = [HalfSpaceZone("floor", (0, 0, p[2] - 0.1), (0, 0, -1)), HalfSpaceZone("wall", (p[0] + 0.1, 0, 0), (1, 0, 0))]
    # Only the hand and the last link meet these planes.
    constraints = [ZoneConstraint(z, skip_capsules=5) for z in zones]
    # Without the acceleration bound: one step shows the projection alone.
    params = ArmParams(max_accel_m_s2=np.inf)
    robot = ArmTeleop("panda", zones=[], extra_constraints=constraints, params=params)
    state = robot.state
    for _ in range(400):  # into the corner
        robot.step(np.array([0.3, 0.0, -0.3]), 0.002)
    M, c = mapping(state, params, robot.R_world_ee_ref)
    v = np.array([0.3, 0.1, -0.3])
    hs = build_halfspaces(state, all_measures(state, constraints, params.activation_m), M, c, v, 0.002, params)
    assert hs.normals.shape[0] >= 2
    expected = quadprog.solve_qp(np.eye(3), v, hs.normals.T.copy(), hs.bounds)[0]
    np.testing.assert_allclose(slide(v, hs.normals, hs.bounds), expected, atol=1e-9)
    report = robot.step(v, 0.002)
    assert {"floor", "wall"} <= {name.split(" ")[0] for name in report.binding}
    assert abs(report.v_executed_m_s[1]) > 0.05  # slides along the edge (y)
    assert abs(report.v_executed_m_s[0]) < 0.02 and abs(report.v_executed_m_s[2]) < 0.02


@pytest.mark.parametrize("robot_name", ROBOT_NAMES)
def test_random_teleoperation_never_crosses_a_limit(robot_name):
    # 1500 steps per robot here; `python -m cobotsafety.tools.invariant` runs 10^5.
    from cobotsafety.tools.invariant import run_invariant

    result = run_invariant(robot_name, steps=1500, seed=3)
    assert result["joint_crossings"] == 0
    assert result["zone_penetrations"] == 0
    assert result["nan_steps"] == 0


def test_recovery_from_inside_a_zone_allows_only_moves_that_reduce_the_violation():
    robot = ArmTeleop("panda", zones=[])
    p = robot.state.p_world_ee
    k = len(robot.state.capsules) - 1
    sphere = SphereZone("blob", tuple(p + np.array([0.0, 0.0, 0.05])), 0.08)  # overlaps the hand
    robot.zones = [sphere]
    zone = ZoneConstraint(sphere, skip_capsules=1)
    d0 = zone.distances(robot.state).min()
    assert d0 < 0
    robot.step(np.array([0.0, 0.0, 0.3]), 0.002)  # deeper into the zone
    assert zone.distances(robot.state).min() >= d0 - 1e-9
    robot.step(np.array([0.0, 0.0, -0.3]), 0.002)  # away from it
    assert zone.distances(robot.state).min() > d0 + 1e-4
    assert k >= 0


def test_singular_pose_gives_finite_smooth_commands():
    robot = ArmTeleop("ur5", zones=[], params=ArmParams(max_accel_m_s2=np.inf))  # the mapping alone, step by step
    robot.reach = ReachLimits(tuple(robot.state.capsule_p0[0]), 0.0, 10.0)  # the singularity alone
    state = robot.state
    state.q = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])  # arm stretched up: singular
    state.update()
    z0 = state.p_world_ee[2]
    report = robot.step(np.array([0.0, 0.0, 0.3]), 0.002)  # stretching further: shrinks to ~0
    assert np.all(np.isfinite(state.q)) and np.linalg.norm(report.v_executed_m_s) < 0.05
    report = robot.step(np.array([0.3, 0.0, 0.0]), 0.002)  # sideways: the arm can still move
    assert np.linalg.norm(report.v_executed_m_s) > 0.1
    previous = None
    for _ in range(200):  # back toward the base: the singular direction, the arm bends away
        report = robot.step(np.array([0.0, 0.0, -0.3]), 0.002)
        assert np.all(np.isfinite(state.q))
        if previous is not None:  # smooth: no jump between steps
            assert np.linalg.norm(report.v_executed_m_s - previous) < 0.05
        previous = report.v_executed_m_s
    assert state.p_world_ee[2] < z0 - 0.02
    report = robot.step(np.array([np.nan, 0, 0]), 0.002)
    assert np.all(np.isfinite(state.q))


def test_the_extended_reach_limit_holds_while_the_arm_stretches():
    robot = ArmTeleop("panda", zones=[])
    shoulder = np.array(robot.reach.shoulder)
    for _ in range(1500):  # drag straight out for 3 s
        robot.step(np.array([0.5, 0.0, 0.2]), 0.002)
    reach = np.linalg.norm(robot.state.p_world_ee - shoulder)
    assert reach <= robot.reach.outer_m + 1e-6
    assert reach > robot.reach.outer_m - 0.05  # it got there and slid/stopped on it


@pytest.mark.parametrize("robot", ["z1", "panda"])
def test_the_filter_alone_keeps_the_limits_and_the_safety_net_stays_a_backstop(robot):
    """z1's orientation hold once drove its wrist into the joint limit through a mis-placed cap
    (the net then scaled 34 % of the steps); the null-space term now gives way near limits."""
    from cobotsafety.tools.invariant import run_invariant

    counts = run_invariant(robot, 3000)
    assert counts["joint_crossings"] == counts["zone_penetrations"] == counts["nan_steps"] == 0
    assert counts["safety_net_steps"] <= 0.01 * counts["steps"]


@pytest.mark.parametrize("robot", ["panda", "ur5", "kinova", "planar"])
def test_mapping_is_the_pseudo_inverse_and_its_secondary_term_moves_no_end_effector(robot):
    """The compiled mapping against numpy: ``M = pinv(J)`` and ``J c = 0`` away from
    singularities (damped below ``w_threshold``: smaller), ``|c_i|`` within half the speed limit."""
    from cobotsafety.arm.step import task_axes

    state = RobotState(robot)
    params = ArmParams()
    R_ref = state.R_world_ee.copy()
    checked = 0
    for _ in range(40):
        state.q = pin.randomConfiguration(state.model)
        state.update()
        J = state.J_ee[task_axes(state)]
        M, c = mapping(state, params, R_ref)
        w = np.sqrt(max(np.linalg.det(J @ J.T), 0.0))
        if w >= params.w_threshold:
            np.testing.assert_allclose(M, np.linalg.pinv(J), atol=1e-9 * max(1.0, np.abs(M).max()))
            np.testing.assert_allclose(J @ c, 0.0, atol=1e-9)  # damped, I - MJ is no exact projector
            checked += 1
        else:
            assert np.linalg.norm(M, 2) <= np.linalg.norm(np.linalg.pinv(J, rcond=1e-12), 2) + 1e-9
        assert np.all(np.abs(c) <= 0.5 * state.model.velocityLimit + 1e-12)
        assert np.all(np.isfinite(M)) and np.all(np.isfinite(c))
    assert checked >= 20
