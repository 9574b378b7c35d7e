"""The compiled kinematics (``arm/kinematics.py``, ``step_kernel.kinematics``) against
pinocchio on random states of every robot, and the Jacobians against finite differences.

States come from ``np.random.default_rng(seed)`` (``oracles.kinematics.random_configuration``),
never from ``pin.randomConfiguration``, whose generator is shared between tests."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.kinematics import (attached_point, drift_along, fastest_capsule_end, frame_jacobian, integrate, log3,
                                        point_jacobian_row)
from cobotsafety.arm.robot_model import RobotModel
from cobotsafety.arm.robots import ROBOTS
from cobotsafety.arm.step_kernel import I_BINDING, I_MOTION_COUNT, OUT_I_HEADER, unpack_robot
from cobotsafety.errors import UnknownRobotError
from compiled_arm import compiled_kinematics, robot
from oracles.kinematics import Kinematics, random_configuration

ROBOT_NAMES = list(ROBOTS)
STATES = 25


def test_every_robot_loads_by_name_and_an_unknown_name_lists_the_known_ones():
    for name in ROBOT_NAMES:
        model = robot(name)
        assert model.model.existFrame(model.spec.ee_frame)
        assert model.home_q.shape == (model.nq,)
        assert len(model.joint_names) == model.nv
    assert (robot("kinova").nq, robot("kinova").nv) == (9, 6)  # three continuous joints: (cos, sin)
    with pytest.raises(UnknownRobotError, match="panda.*ur5.*kinova.*z1.*xarm7.*iiwa"):
        RobotModel.load("kr6")


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_compiled_kinematics_equal_pinocchio(name):
    model = robot(name)
    rng = np.random.default_rng(100 + ROBOT_NAMES.index(name))
    for _ in range(STATES):
        q = random_configuration(model.model, rng)
        oracle = Kinematics(model, q)
        kin, p_ee, R_ee, J6, oR, op, p0, p1 = compiled_kinematics(model, q)
        for j in range(1, model.model.njoints):
            np.testing.assert_allclose(oR[j], oracle.data.oMi[j].rotation, rtol=0, atol=1e-12)
            np.testing.assert_allclose(op[j], oracle.data.oMi[j].translation, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p_ee, oracle.p_ee, rtol=0, atol=1e-12)
        np.testing.assert_allclose(R_ee, oracle.R_ee, rtol=0, atol=1e-12)
        np.testing.assert_allclose(J6, oracle.J6_ee, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p0, oracle.p0, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p1, oracle.p1, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_point_jacobian_rows_equal_pinocchio(name):
    """``u @ J_p`` for random directions ``u`` and points ``p`` fixed to every joint."""
    model = robot(name)
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    idx_v, support, axes = unpacked[6], unpacked[7], unpacked[10]
    rng = np.random.default_rng(200 + ROBOT_NAMES.index(name))
    out = np.empty(model.nv)
    for _ in range(STATES):
        q = random_configuration(model.model, rng)
        oracle = Kinematics(model, q)
        _, _, _, _, oR, op, _, _ = compiled_kinematics(model, q)
        for joint in range(1, model.model.njoints):
            u = rng.normal(size=3)
            p = op[joint] + rng.normal(size=3) * 0.3
            point_jacobian_row(u, p, joint, oR, op, axes, idx_v, support, out)
            np.testing.assert_allclose(out, u @ oracle.point_jacobian(joint, p), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_a_points_drift_equals_pinocchios_classical_acceleration(name):
    """``drift_along`` (``u . dJ/dt qdot``, what pulls a limitation's row at a joint velocity
    with no joint acceleration) against pinocchio's classical acceleration of the same point
    (``forwardKinematics(q, qdot, 0)``: ``a_o + w x v_o + w x (w x r)`` in the joint's frame),
    on the frame Jacobians of points fixed to every joint and on the end-effector's Jacobian."""
    model = robot(name)
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    idx_v, support, axes = unpacked[6], unpacked[7], unpacked[10]
    rng = np.random.default_rng(250 + ROBOT_NAMES.index(name))
    data = model.model.createData()
    scratch = np.empty((6, model.nv))
    ee = model.model.getFrameId(model.spec.ee_frame)
    worst = 0.0
    for _ in range(STATES):
        q = random_configuration(model.model, rng)
        qdot = rng.normal(size=model.nv) * 2.0
        pin.forwardKinematics(model.model, data, q, qdot, np.zeros(model.nv))
        pin.updateFramePlacements(model.model, data)
        _, p_ee, _, J6, oR, op, _, _ = compiled_kinematics(model, q)
        for joint in range(1, model.model.njoints):
            u = rng.normal(size=3)
            p = op[joint] + rng.normal(size=3) * 0.3
            R = data.oMi[joint].rotation
            r = R.T @ (p - data.oMi[joint].translation)  # the point in the joint's frame
            v, a = data.v[joint], data.a[joint]
            w = v.angular
            classical = R @ (a.linear + np.cross(w, v.linear) + np.cross(w, np.cross(w, r)) + np.cross(a.angular, r))
            frame_jacobian(p, joint, oR, op, axes, idx_v, support, scratch)
            got = drift_along(u, scratch, qdot)
            assert got == pytest.approx(u @ classical, rel=1e-9, abs=1e-10)
            worst = max(worst, abs(u @ classical))
        u = rng.normal(size=3)
        hand = pin.getFrameClassicalAcceleration(model.model, data, ee, pin.LOCAL_WORLD_ALIGNED).linear
        assert drift_along(u, J6, qdot) == pytest.approx(u @ hand, rel=1e-9, abs=1e-10)
    assert worst > 1.0  # the drifts compared are not all tiny


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_fastest_capsule_end_is_the_fastest_of_pinocchios_point_velocities(name):
    """``fastest_capsule_end`` against pinocchio's velocities of the capsules' end points
    (``forwardKinematics(q, qdot)``: ``v_o + w x r`` of each point's joint), at random states."""
    model = robot(name)
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    parent, idx_v, cap_joint, axes = unpacked[4], unpacked[6], unpacked[8], unpacked[10]
    rng = np.random.default_rng(270 + ROBOT_NAMES.index(name))
    data = model.model.createData()
    for _ in range(STATES):
        q = random_configuration(model.model, rng)
        qdot = rng.normal(size=model.nv) * 2.0
        pin.forwardKinematics(model.model, data, q, qdot)
        _, _, _, _, oR, op, p0, p1 = compiled_kinematics(model, q)
        speeds = []
        for c, joint in enumerate(int(j) for j in cap_joint):
            R, o = data.oMi[joint].rotation, data.oMi[joint].translation
            v, w = R @ data.v[joint].linear, R @ data.v[joint].angular  # in the world's axes
            speeds += [np.linalg.norm(v + np.cross(w, p - o)) for p in (p0[c], p1[c])]
        got = fastest_capsule_end(oR, op, axes, parent, idx_v, cap_joint, p0, p1, qdot)
        assert got == pytest.approx(max(speeds), rel=1e-12, abs=1e-12)
        assert got > 0.1  # moving: the speeds compared are not all zero


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_jacobians_match_finite_differences(name):
    """The end-effector's Jacobian (translation and rotation) and a point's Jacobian row
    against central differences of the compiled kinematics along random joint velocities
    (pinocchio's ``integrate`` moves the state)."""
    model = robot(name)
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    idx_v, support, axes = unpacked[6], unpacked[7], unpacked[10]
    rng = np.random.default_rng(300 + ROBOT_NAMES.index(name))
    eps = 1e-6
    row, moved = np.empty(model.nv), np.empty(3)
    for _ in range(8):
        q = random_configuration(model.model, rng)
        _, p_ee, R_ee, J6, oR, op, _, _ = compiled_kinematics(model, q)
        joint = int(rng.integers(1, model.model.njoints))
        p_local = rng.normal(size=3) * 0.2
        p = np.empty(3)
        attached_point(oR, op, joint, p_local, p)
        u = rng.normal(size=3)
        point_jacobian_row(u, p, joint, oR, op, axes, idx_v, support, row)
        for _ in range(3):
            qdot = rng.normal(size=model.nv)
            ends = []
            for sign in (1.0, -1.0):
                _, p_e, R_e, _, oR_e, op_e, _, _ = compiled_kinematics(model, pin.integrate(model.model, q, sign * eps * qdot))
                attached_point(oR_e, op_e, joint, p_local, moved)
                ends.append((p_e.copy(), R_e.copy(), moved.copy()))
            (pa, Ra, xa), (pb, Rb, xb) = ends
            np.testing.assert_allclose(J6[:3] @ qdot, (pa - pb) / (2 * eps), rtol=1e-6, atol=1e-7)
            omega = pin.log3(Ra @ Rb.T) / (2 * eps)
            np.testing.assert_allclose(J6[3:] @ qdot, omega, rtol=1e-6, atol=1e-7)
            assert row @ qdot == pytest.approx(u @ (xa - xb) / (2 * eps), rel=1e-6, abs=1e-7)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_integrate_equals_pinocchio_and_keeps_continuous_joints_on_the_circle(name):
    model = robot(name)
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    jtype, idx_q, idx_v = unpacked[3], unpacked[5], unpacked[6]
    rng = np.random.default_rng(400 + ROBOT_NAMES.index(name))
    out = np.empty(model.nq)
    for scale in (1e-4, 1e-2, 1.0, 3.0):
        for _ in range(10):
            q = random_configuration(model.model, rng)
            v = rng.normal(size=model.nv) * scale
            integrate(q, v, jtype, idx_q, idx_v, out)
            np.testing.assert_allclose(out, pin.integrate(model.model, q, v), rtol=0, atol=1e-12)
    # A (cos, sin) pair a little off the unit circle comes back to it (to first order) as in
    # pinocchio.
    for _ in range(10):
        q = random_configuration(model.model, rng)
        for j in range(1, model.model.njoints):
            if model.model.joints[j].nq == 2:
                q[model.model.joints[j].idx_q:model.model.joints[j].idx_q + 2] *= 1.0 + rng.uniform(-1e-6, 1e-6)
        v = rng.normal(size=model.nv)
        integrate(q, v, jtype, idx_q, idx_v, out)
        np.testing.assert_allclose(out, pin.integrate(model.model, q, v), rtol=0, atol=1e-12)
    q = model.home_q.copy()
    for _ in range(2000):  # a long run of small steps: the (cos, sin) pairs stay unit vectors
        integrate(q, rng.normal(size=model.nv) * 0.01, jtype, idx_q, idx_v, out)
        q = out.copy()
    for j in range(1, model.model.njoints):
        joint = model.model.joints[j]
        if joint.nq == 2:
            assert np.hypot(*q[joint.idx_q:joint.idx_q + 2]) == pytest.approx(1.0, abs=1e-12)


def test_log3_equals_pinocchio_on_every_branch():
    """Random rotations at any angle, near 0 (the Taylor branch) and near pi (the axis branch)."""
    rng = np.random.default_rng(500)
    angles = np.concatenate([rng.uniform(0.0, np.pi, 300), 10.0 ** rng.uniform(-12, -2, 100),
                             np.pi - 10.0 ** rng.uniform(-12, -2, 100), [0.0, np.pi]])
    for angle in angles:
        axis = rng.normal(size=3)
        R = pin.exp3(angle * axis / np.linalg.norm(axis))
        np.testing.assert_allclose(log3(R), pin.log3(R), rtol=0, atol=_log3_tolerance(angle))
    # Not quite orthonormal (a rotation read back from a float32 buffer): renormalised the same way.
    for _ in range(50):
        R = pin.exp3(rng.normal(size=3)).astype(np.float32).astype(float)
        np.testing.assert_allclose(log3(R), pin.log3(R), rtol=0, atol=_log3_tolerance(np.linalg.norm(pin.log3(R))))


def _log3_tolerance(angle: float) -> float:
    """1e-12, times the arccos branch's amplification of the trace's rounding (1 / sin(angle),
    at most 100: the axis branch takes over 3.5 mrad from pi). The same formulas rounded by
    another build or CPU differ that much: pinocchio 4.1's wheel and ours on an AMD EPYC by up
    to 2.9e-12 at 10 mrad from pi (pinocchio 3 and ours on an Intel Xeon: under 1e-12)."""
    return 1e-12 * min(1.0 / max(np.sin(angle), 1e-300), 100.0) if angle > 0.5 * np.pi else 1e-12


@pytest.mark.parametrize("name", ["panda", "kinova"])
def test_a_step_takes_the_previous_steps_kinematics_only_at_their_q_and_leaves_them_unchanged(monkeypatch, name):
    """Each step is handed the previous step's output (its kinematics at its q_next); run again
    on copies with no previous output, or with an older step's (another q), it must give the
    same state and outputs bit for bit, and the previous output must not change."""
    from cobotsafety.arm import controller as controller_module
    from cobotsafety.arm.controller import ArmController
    from cobotsafety.human.body import HumanCapsules

    controller = ArmController(name)
    p = controller.state.p_world_ee
    controller.set_human(HumanCapsules(np.array([[p[0], p[1] + 0.4, 0.2]]), np.array([[p[0], p[1] + 0.4, 1.6]]),
                                       np.array([0.2]), ("torso",)))
    original = controller_module.arm_step
    nq = controller.model.nq
    older: list[np.ndarray] = []
    seen = {"reused": 0, "older_elsewhere": 0}

    def written(out_i):  # the header and the row codes it counts
        return out_i[:OUT_I_HEADER + out_i[I_BINDING] + out_i[I_MOTION_COUNT]].tobytes()

    def run(kin_f, state_f, rest):
        state = state_f.copy()
        out_f, out_i = np.empty_like(rest[-2]), np.empty_like(rest[-1])
        status = original(state, kin_f, *rest[:-2], out_f, out_i)
        return [status, state.tobytes(), out_f.tobytes(), written(out_i)]

    def checked_step(state_f, kin_f, *rest):
        kin_before = kin_f.copy()
        fresh = run(np.zeros(0), state_f, rest)
        if older:
            older_q = older[-1][:nq]
            seen["older_elsewhere"] += not np.array_equal(older_q, state_f[:nq])
            assert run(older[-1], state_f, rest) == fresh
        seen["reused"] += kin_f.shape[0] > nq and np.array_equal(kin_f[:nq], state_f[:nq])
        status = original(state_f, kin_f, *rest)
        assert [status, state_f.tobytes(), rest[-2].tobytes(), written(rest[-1])] == fresh
        assert kin_f.tobytes() == kin_before.tobytes()
        older.append(kin_f)
        return status

    monkeypatch.setattr(controller_module, "arm_step", checked_step)
    rng = np.random.default_rng(7)
    for _ in range(60):
        controller.set_human(controller.human_frame)
        controller.step(0.3 * rng.normal(size=3), 0.002)
    assert seen["reused"] == 60 and seen["older_elsewhere"] >= 50
