"""The packed fast path (``cobotsafety.arm.packed``) equals the reference step (``arm.step.step``).

The oracles: pinocchio for the kinematics (placements, Jacobian, ``integrate``, ``log3``), and
the reference step itself (constraint classes, ``slide``) on random states of every robot,
with the demo zones, the table, the reach and joint limits and a moving human beside the arm.
"""

from __future__ import annotations

import os
from collections import Counter

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.packed import PackedArm, _contradiction_reason
from cobotsafety.arm.packed_kernel import filter_kernel, kinematics
from cobotsafety.arm.packed_kinematics import integrate, log3
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.robots import ROBOTS
from cobotsafety.arm.step import ArmParams, anticipative_command, step, task_axes
from cobotsafety.arm.teleop import ArmTeleop, default_constraints, default_zones, reach_limits
from cobotsafety.control.human_constraint import HumanCapsulesConstraint
from cobotsafety.human.body import HumanCapsules

STATES_PER_ROBOT = int(os.environ.get("COBOTSAFETY_PACKED_STATES", "500"))
"""Random states per robot (the reference step costs ~2-6 ms each on a loaded 2-core machine);
more with ``COBOTSAFETY_PACKED_STATES=10000``."""
EXACT_M = 1e-12
"""Next ``q`` [rad] and half-spaces (relative to the row's size) of a plain step: both paths do
the same arithmetic in nearly the same order, what differs is rounding (~1e-16)."""
RELAXED_M = 1e-6
"""Next ``q`` [rad] of a step whose retreats were relaxed (``projection.relax``: a least-squares
stage weighted 1e-2, conditioned ~1e4 worse) or scaled down by the safety net's bisection (its
2^-25 resolution on the step): rounding moves its result by up to ~1e-7 rad."""
STOP_TIE_M_S = 1e-9
HALFSPACE_NEAR_SINGULAR = 1e-9


def random_q(model, rng) -> np.ndarray:
    """A configuration within the joint limits (clipped to +-pi), drawn from ``rng`` (not from
    ``pin.randomConfiguration``, whose C generator is shared by every test of the session: the
    states would depend on which tests ran before)."""
    lower = np.maximum(model.lowerPositionLimit, -np.pi)
    upper = np.minimum(model.upperPositionLimit, np.pi)
    q = pin.neutral(model)
    for joint in model.joints[1:]:
        i = joint.idx_q
        if joint.nq == 1:
            q[i] = rng.uniform(lower[i], upper[i])
        elif joint.nq == 2 and joint.nv == 1:  # continuous: (cos, sin) of a uniform angle
            angle = rng.uniform(-np.pi, np.pi)
            q[i], q[i + 1] = np.cos(angle), np.sin(angle)
        else:
            raise NotImplementedError(joint.shortname())
    return q


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_kinematics_equal_pinocchio(robot):
    state = RobotState(robot)
    packed = PackedArm(state)
    model, data = state.model, state.model.createData()
    rng = np.random.default_rng(1)
    for _ in range(200):
        q = random_q(model, rng)
        oR, op, p_ee, R_ee, J6, p0, p1, _ = kinematics(
            q, packed.robot_int, packed.jtype, packed.axes, packed.parent, packed.idx_q, packed.idx_v,
            packed.placement_R, packed.placement_t, packed.support, packed.ee_R, packed.ee_t, packed.cap_joint,
            packed.cap_p0l, packed.cap_p1l)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for j in range(model.njoints):
            np.testing.assert_allclose(oR[j], data.oMi[j].rotation, atol=1e-14)
            np.testing.assert_allclose(op[j], data.oMi[j].translation, atol=1e-14)
        np.testing.assert_allclose(p_ee, data.oMf[state.ee_frame_id].translation, atol=1e-14)
        np.testing.assert_allclose(R_ee, data.oMf[state.ee_frame_id].rotation, atol=1e-14)
        J = pin.getFrameJacobian(model, data, state.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(J6, J, atol=1e-14)
        state.q = q
        state.update()
        np.testing.assert_allclose(p0, state.capsule_p0, atol=1e-14)
        np.testing.assert_allclose(p1, state.capsule_p1, atol=1e-14)
        v = rng.normal(size=model.nv) * rng.choice([1e-3, 0.1, 2.0])
        out = np.empty(model.nq)
        integrate(q, v, packed.jtype, packed.idx_q, packed.idx_v, out)
        np.testing.assert_allclose(out, pin.integrate(model, q, v), atol=1e-15)


def test_log3_equals_pinocchio():
    rng = np.random.default_rng(2)
    for scale in (1e-12, 1e-7, 1e-4, 0.1, 1.0, 3.0, np.pi - 1e-3, np.pi - 1e-7):
        for _ in range(50):
            axis = rng.normal(size=3)
            R = pin.exp3(axis / np.linalg.norm(axis) * scale)
            # Near pi the angle-axis is ill-conditioned (error / (pi - theta)): both sides agree
            # to what the rotation matrix's rounding allows.
            np.testing.assert_allclose(log3(R), pin.log3(R), atol=1e-15 / max(np.pi - scale, 1e-3) * 100)


def _human_beside(state: RobotState, rng, count: int = 5):
    """``count`` capsules within ~0.3 m of a random robot capsule, moving at up to ~1 m/s."""
    c = rng.integers(len(state.capsules))
    centre = 0.5 * (state.capsule_p0[c] + state.capsule_p1[c]) + rng.normal(size=3) * 0.25
    p0 = centre + rng.normal(size=(count, 3)) * 0.15
    p1 = p0 + rng.normal(size=(count, 3)) * 0.15
    return HumanCapsules(p0, p1, rng.uniform(0.03, 0.12, count), tuple(f"h{i}" for i in range(count)),
                         v0_b_m_s=rng.normal(size=(count, 3)) * 0.5, v1_b_m_s=rng.normal(size=(count, 3)) * 0.5)


def _filters_agree(expected, v_previous, dt_s: float, params: ArmParams, state: RobotState) -> tuple[bool, bool]:
    """Whether ``packed_kernel.filter_kernel`` and ``step.anticipative_command`` give the same
    command (1e-9 m/s), violations and reason on the reference's own half-spaces; and whether
    the reference's filter met a contradiction or relaxed (a fragile branch)."""
    hs = expected.halfspaces
    axes = task_axes(state)
    vk = np.ascontiguousarray(expected.v_desired[axes])
    previous = None if v_previous is None else np.asarray(v_previous, dtype=float)[axes]
    command, violation, reason = anticipative_command(vk, hs, previous, dt_s, params)
    detail = np.zeros(4)
    try:
        got, got_violation, ok = filter_kernel(
            vk, np.ascontiguousarray(hs.normals), hs.bounds,
            np.zeros(len(axes)) if previous is None else np.ascontiguousarray(previous), previous is not None, dt_s,
            params.max_accel_m_s2, detail)
    except np.linalg.LinAlgError:  # a singular active set: the packed step hands it to the reference
        return False, True
    got_reason = _contradiction_reason(detail) if detail[0] else ""
    agree = (ok and got_reason == reason and np.allclose(got, command, rtol=0.0, atol=1e-9)
             and np.allclose(got_violation, violation, rtol=0.0, atol=1e-9))
    return bool(agree), bool(reason) or bool(np.any(violation > 0))


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_packed_step_equals_reference(robot):
    rng = np.random.default_rng(sum(map(ord, robot)))
    reference, fast = RobotState(robot), RobotState(robot)
    packed = PackedArm(fast)
    params = ArmParams()
    human = HumanCapsulesConstraint()
    zones = default_zones(reference)
    constraints = default_constraints(reference, zones, reach_limits(reference) if robot != "planar" else None)
    constraints = constraints + [human]
    R_ref = reference.R_world_ee.copy()
    outcomes = Counter()
    worst = Counter()
    for i in range(STATES_PER_ROBOT):
        q = random_q(reference.model, rng)
        reference.q, fast.q = q.copy(), q.copy()
        reference.update()
        fast.update()
        human.set_human(_human_beside(reference, rng))
        v = rng.normal(size=3) * rng.uniform(0.0, 1.0)
        # The previous command: often near this one (the acceleration bound binds or not).
        v_previous = None if i % 3 == 0 else v + rng.normal(size=3) * rng.choice([0.001, 0.01, 0.1])
        method = "stop" if i % 10 == 0 else "anticipative"
        dt_s = 0.002 if i % 7 else 0.01
        expected = step(reference, v, dt_s, constraints, params, method, R_ref, None, v_previous)
        got = packed.step(fast, v, dt_s, constraints, params, method, R_ref, None, v_previous)
        context = f"{robot} state {i}: q={q.tolist()}"
        # The half-spaces: always the same rows, equal to rounding (relative to the row's size;
        # near a singularity the mapping's conditioning amplifies rounding: HALFSPACE_NEAR_SINGULAR).
        assert tuple(got.halfspaces.names) == expected.halfspaces.names, context
        size = np.maximum(1.0, np.abs(expected.halfspaces.normals).max(axis=1, initial=0.0))
        error = max(float((np.abs(got.halfspaces.normals - expected.halfspaces.normals).max(axis=1, initial=0.0)
                           / size).max(initial=0.0)),
                    float((np.abs(got.halfspaces.bounds - expected.halfspaces.bounds)
                           / np.maximum(1.0, np.abs(expected.halfspaces.bounds))).max(initial=0.0)))
        assert error <= HALFSPACE_NEAR_SINGULAR, context
        outcomes["half-spaces exact"] += error <= EXACT_M
        dq = float(np.max(np.abs(fast.q - reference.q)))
        kind = "relaxed" if expected.relaxed or expected.net_scale < 1.0 else "plain"
        # "stopped" is |command| <= 1e-12 m/s: a command of that size is a tie with rounding.
        tie = max(np.abs(got.v_commanded).max(), np.abs(expected.v_commanded).max()) <= STOP_TIE_M_S
        same = (got.binding == expected.binding and got.relaxed == expected.relaxed
                and (got.stopped == expected.stopped or tie))
        outcomes["stopped tie"] += got.stopped != expected.stopped
        outcomes[kind] += 1
        outcomes[f"{kind} exact"] += same and dq <= EXACT_M
        outcomes[f"{kind} within"] += same and dq <= (EXACT_M if kind == "plain" else RELAXED_M)
        outcomes[f"{kind} q within {RELAXED_M:g}"] += dq <= RELAXED_M
        outcomes["binding"] += bool(expected.binding)
        worst[kind] = max(worst[kind], dq)
        if method == "anticipative":
            # The filter alone on the same half-spaces: where the two steps took different
            # branches (relaxed / approaching nothing), their inputs' last bits decided it.
            agree, flipped = _filters_agree(expected, v_previous, dt_s, params, reference)
            outcomes["filter agrees on the same rows"] += agree
            outcomes["branch flipped by rounding"] += flipped and got.reason[:7] != expected.reason[:7]
    print(robot, dict(outcomes), {k: f"{w:.1e}" for k, w in worst.items()}, dict(packed.fallbacks))
    assert outcomes["half-spaces exact"] >= 0.99 * STATES_PER_ROBOT, outcomes
    # Plain steps (no relaxation, no bisection): the same decisions and q to 1e-12, but for
    # ties of a threshold with rounding (a command of ~1e-12 m/s is "stopped" or not) and
    # degenerate active sets (many rows through one point) that move q by up to ~1e-9.
    assert outcomes["plain within"] >= 0.97 * outcomes["plain"], outcomes
    assert outcomes["plain q within 1e-06"] >= 0.995 * outcomes["plain"], outcomes
    # Relaxed or bisected steps: the same decisions and q to 1e-6 but for rare ties, and
    # degenerate relaxations (20+ retreats contradicting at once) whose branch, relaxed by least
    # squares or approaching nothing, the inputs' last bits decide: on the same half-spaces the
    # compiled filter equals the reference's (``filter agrees``), so such a flip comes from the
    # ~1e-16 rounding of the half-spaces, not from the filter.
    anticipative = STATES_PER_ROBOT - STATES_PER_ROBOT // 10
    assert outcomes["filter agrees on the same rows"] >= 0.98 * anticipative, outcomes
    assert outcomes["branch flipped by rounding"] <= 0.06 * anticipative, outcomes
    assert outcomes["relaxed within"] + outcomes["branch flipped by rounding"] >= 0.97 * outcomes["relaxed"], outcomes
    assert outcomes["relaxed q within 1e-06"] + outcomes["branch flipped by rounding"] >= 0.99 * outcomes["relaxed"], outcomes
    # The states exercise what the kernel does, and it took almost all of them itself. These
    # states are adversarial (a random pose, a human within 0.3 m, most steps relaxed): the
    # case left to the reference (a capsule inside the box zone) is 0-3 % of them here.
    assert outcomes["binding"] > STATES_PER_ROBOT // 4, outcomes
    assert outcomes["plain"] > STATES_PER_ROBOT // 10, outcomes
    assert sum(packed.fallbacks.values()) <= 0.04 * STATES_PER_ROBOT, packed.fallbacks


def test_pinocchio_data_is_refreshed_when_read():
    teleop = ArmTeleop("panda")
    teleop.step(np.array([0.2, 0.0, 0.0]), 0.002)
    data = teleop.state.data
    frame = teleop.state.ee_frame_id
    np.testing.assert_allclose(data.oMf[frame].translation, teleop.state.p_world_ee, atol=1e-14)
    expected = pin.getFrameJacobian(teleop.state.model, data, frame, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(teleop.state.J_ee, expected[:3], atol=1e-14)


def test_unknown_constraint_falls_back_to_the_reference():
    from cobotsafety.arm.constraints import ArmConstraint, Measures

    class Nothing(ArmConstraint):
        name = "nothing"

        def measures(self, state, activation_m=np.inf):
            return Measures.empty(state.nv)

    fast, reference = ArmTeleop("ur5", extra_constraints=[Nothing()]), ArmTeleop("ur5", extra_constraints=[Nothing()],
                                                                                   fast=False)
    for _ in range(5):
        a = fast.step(np.array([0.1, 0.2, 0.0]), 0.002)
        b = reference.step(np.array([0.1, 0.2, 0.0]), 0.002)
        np.testing.assert_array_equal(a.p_base_ee_m, b.p_base_ee_m)
    assert fast.packed.fallbacks == {"constraint type": 5}


@pytest.mark.parametrize("robot", ["panda", "ur5"])
def test_human_minimum_is_the_smallest_pair(robot):
    """``HumanCapsulesConstraint.minimum`` (one compiled call) is the first smallest of
    ``pairs``' distances (the numpy broadcast of ``capsule_distance``), with its points."""
    from cobotsafety.geometry.capsule import capsule_distance

    rng = np.random.default_rng(7)
    state = RobotState(robot)
    human = HumanCapsulesConstraint()
    for _ in range(200):
        state.q = random_q(state.model, rng)
        state.update()
        human.set_human(_human_beside(state, rng, count=int(rng.integers(1, 6))))
        d, p_robot, p_human = human.minimum(state)
        s = human.skip_capsules
        oracle = capsule_distance(state.capsule_p0[s:, None], state.capsule_p1[s:, None], state.capsule_radius[s:, None],
                                  human.p0[None], human.p1[None], human.radius[None])
        distances = np.asarray(oracle[0])
        i, j = np.unravel_index(np.argmin(distances), distances.shape)
        assert d == pytest.approx(distances[i, j], abs=1e-12)
        np.testing.assert_allclose(p_robot, np.asarray(oracle[1])[i, j], atol=1e-12)
        np.testing.assert_allclose(p_human, np.asarray(oracle[2])[i, j], atol=1e-12)
    human.set_human(None)
    d, p_robot, p_human = human.minimum(state)
    assert d == np.inf and np.all(np.isnan(p_robot)) and np.all(np.isnan(p_human))
