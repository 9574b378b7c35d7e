"""The joint-space filter (``arm/joint_filter.py``) against its QP written plainly with quadprog
(``oracles/joint_filter.py``), paper 1's 2D rule, and the speed cap as a norm."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from cobotsafety.arm.joint_filter import (HAND, LEVEL_EXACT, LEVEL_RELAXED, LEVEL_SMOOTHNESS, LIMITATION, MOTION,
                                          PLAN, RECOVERY, SPEED_CUTS, VELOCITY, filter_rows)
from oracles.joint_filter import ahead_cap_qp, filter_qp, lexicographic_qp, stage1_objective
from oracles.projection import kkt_residual, paper_rule_2d

NO_CAP = np.inf


def filtered(q0, B, N, b, group, count, J, speed_cap, speed_limit, ramp=None):
    """``filter_rows`` with the recoveries easing straight to approach nothing (``ramp`` None)."""
    ramp = np.zeros(len(b)) if ramp is None else ramp
    return filter_rows(q0, B, N, b, ramp, group, count, J, speed_cap, speed_limit, np.zeros(3), np.zeros(3),
                       speed_cap)


def tolerance(B: np.ndarray) -> float:
    """How close kernel and quadprog agree on ``qdot`` [rad/s] and the violations: both meet the
    optimality conditions in ``z`` to ~1e-12 (measured), and ``B``'s null-space columns
    (``Z / eps``, entries up to ~100) and active sets conditioned up to ~1e5 carry that to
    ~4e-9 in ``qdot`` (seed 41: worst 4.2e-9 with ``max |B|`` 92)."""
    return 1e-10 * max(1.0, float(np.abs(B).max()))


def task(rng: np.random.Generator, nv: int, eps: float = 0.01):
    """A random arm's task: ``J`` (3, nv), ``B = [J^+ | Z / eps]`` and ``q0 = J^+ v + c``."""
    J = rng.normal(size=(3, nv))
    M = np.linalg.pinv(J)
    B = np.hstack([M, scipy.linalg.null_space(J) / eps])
    q0 = M @ rng.normal(size=3) * 0.3 + (np.eye(nv) - M @ J) @ rng.normal(size=nv) * 0.1
    return J, B, q0


def rows(groups_and_rows, nv):
    """``(N, b, group, count)`` with room for the speed cuts after ``count``."""
    N = np.vstack([r for _, r, _ in groups_and_rows] + [np.zeros((SPEED_CUTS, nv))])
    b = np.concatenate([[x for _, _, x in groups_and_rows], np.zeros(SPEED_CUTS)])
    group = np.array([g for g, _, _ in groups_and_rows] + [0] * SPEED_CUTS, dtype=np.int64)
    return np.ascontiguousarray(N), b, group, len(groups_and_rows)


def hard_problem(rng, nv, feasible_point, q_prev):
    """Limitation rows through (or short of) a feasible point, the joints' speed limits and a
    motion box around the previous command that holds the feasible point."""
    vel = np.full(nv, 2.0)
    found = []
    for _ in range(int(rng.integers(1, 2 * nv))):
        a = rng.normal(size=nv) * 10.0 ** rng.uniform(-1, 1)
        found.append((LIMITATION, a, a @ feasible_point - abs(rng.normal()) * rng.integers(0, 2)))
    for j in range(nv):
        for sign in (1.0, -1.0):
            e = np.zeros(nv)
            e[j] = sign
            found.append((VELOCITY, e, -vel[j]))
            width = abs(feasible_point[j] - q_prev[j]) + rng.uniform(0.0, 0.2)
            found.append((MOTION, e, sign * q_prev[j] - width))
    return found


def test_hard_rows_equal_the_quadprog_qp_on_random_problems():
    rng = np.random.default_rng(41)
    worst, binding, quadprog_failures = 0.0, 0, 0
    for _ in range(1500):
        nv = int(rng.integers(3, 8))
        J, B, q0 = task(rng, nv)
        feasible = rng.uniform(-1.5, 1.5, nv)
        N, b, group, count = rows(hard_problem(rng, nv, feasible, feasible + rng.normal(size=nv) * 0.1), nv)
        qdot, violation, level, used = filtered(q0, B, N.copy(), b.copy(), group.copy(), count, J, NO_CAP, NO_CAP)
        assert level == LEVEL_EXACT and used == count and not violation.any()
        binding += np.any(N[:count] @ q0 < b[:count])
        try:
            expected = filter_qp(q0, B, N[:count], b[:count])
        except ValueError:  # quadprog gives up on a degenerate vertex: the optimality conditions
            G, h = N[:count] @ B, b[:count] - N[:count] @ q0
            z = np.linalg.lstsq(B, qdot - q0, rcond=None)[0]
            scale = np.linalg.norm(G, axis=1)
            assert kkt_residual(z, np.zeros(B.shape[1]), G / scale[:, None], h / scale) <= 1e-9
            quadprog_failures += 1
            continue
        worst = max(worst, float(np.max(np.abs(qdot - expected))) / tolerance(B))
    assert worst <= 1.0
    assert binding > 1000 and quadprog_failures < 50  # most problems had to move the command


def acceptance(b: np.ndarray) -> float:
    """``relax_kernel``'s acceptance of a row: 1e-6 of the bounds' size."""
    return 1e-6 * max(1.0, float(np.abs(b).max()))


def assert_reaches_stage1_optimum(q0, B, N, b, violation, violation_qp, rel: float, where: tuple) -> None:
    """The kernel's violations reach quadprog's stage-1 optimum to ``rel`` (relative), each
    objective read with the kernel's acceptance as its hair (``stage1_objective``)."""
    hair = acceptance(b)
    optimum = stage1_objective(q0, B, N, b, violation_qp, hair)
    reached = stage1_objective(q0, B, N, b, violation, hair)
    assert reached <= optimum * (1.0 + rel) + 1e-12, (*where, reached, optimum)


def test_motion_rows_give_way_lexicographically_when_the_hard_rows_force_them():
    """A limitation that needs more than the motion box allows: the motion rows are relaxed by
    least squares (safety over smoothness), the rest is the closest command; against the two
    stages written as quadprog QPs. With plan rows (soft at the first level) the same. When
    every row can hold at once nothing gives way (the exact QP)."""
    rng = np.random.default_rng(42)
    tested = {LEVEL_SMOOTHNESS: 0, LEVEL_EXACT: 0, "feasible": 0}
    for k in range(600):
        nv = int(rng.integers(3, 8))
        J, B, q0 = task(rng, nv)
        q_prev = rng.uniform(-0.5, 0.5, nv)
        found = hard_problem(rng, nv, q_prev, q_prev)  # the box around q_prev holds q_prev
        a = rng.normal(size=nv)
        if k % 2 == 0:  # a retreat beyond the motion box: only the motion rows can give way
            found.append((LIMITATION, a, a @ q_prev + rng.uniform(0.5, 2.0)))
            soft_groups, level_expected = (PLAN, MOTION), LEVEL_SMOOTHNESS
        else:  # a plan row beyond the motion box: the plan gives way, the motion box holds
            found.append((PLAN, a, a @ q_prev + rng.uniform(0.5, 2.0)))
            soft_groups, level_expected = (PLAN,), LEVEL_EXACT
        N, b, group, count = rows(found, nv)
        qdot, violation, level, _ = filtered(q0, B, N.copy(), b.copy(), group.copy(), count, J, NO_CAP, NO_CAP)
        try:  # the box may be wide enough for the new row: then every row holds
            exact = filter_qp(q0, B, N[:count], b[:count])
        except ValueError:
            exact = None
        if exact is not None:
            assert level == LEVEL_EXACT and not violation.any()
            np.testing.assert_allclose(qdot, exact, rtol=0, atol=tolerance(B))
            tested["feasible"] += 1
            continue
        soft = np.isin(group[:count], soft_groups)
        try:
            expected, violation_qp = lexicographic_qp(q0, B, N[:count], b[:count], soft)
        except ValueError:  # the retreat is beyond the speed limits too: not this test's case
            continue
        assert level == level_expected
        # Stage 1 weighs the command by w = RELAXATION_COMMAND_WEIGHT (1e-2): its rows are
        # ``N B / w``, entries up to ~1e4, and its optimum can be flat along a row: two solvers
        # rounding differently land at different violations of the same objective (seed 42,
        # problem 224: 1.3e-4 apart on an AMD EPYC, objectives equal to 1e-7; under 2e-6 apart
        # on an Intel Xeon). So the kernel's violations must reach quadprog's optimum (to 1e-5
        # relative: seed 42's worst 1.4e-6), and agree with them to 1e-3.
        assert_reaches_stage1_optimum(q0, B, N[:count], b[:count], violation[:count], violation_qp, 1e-5, (k,))
        np.testing.assert_allclose(violation[:count], violation_qp, rtol=0, atol=1e-3)
        # Stage 2 moves that difference to the command through its active set (``Z / eps``:
        # entries up to ~100): seed 42's worst 1.3e-4 rad/s (2.2e-5 on the Xeon).
        np.testing.assert_allclose(qdot, expected, rtol=0, atol=1e-3)
        hard = ~soft
        worst_hard = float(np.max(b[:count][hard] - N[:count][hard] @ qdot))
        # The limitation and speed rows hold, to relax_kernel's acceptance (1e-6 of the bounds'
        # size: seed 42's worst miss 1.9e-7 on bounds of ~3).
        assert worst_hard <= acceptance(b[:count]), (k, level, worst_hard)
        assert violation[:count][soft].max() > 0.0
        tested[level] += 1
    assert tested[LEVEL_SMOOTHNESS] > 100 and tested[LEVEL_EXACT] > 150 and tested["feasible"] > 0, tested


def test_the_hands_limits_give_way_before_the_joints():
    """A limitation that needs more than the joints' and the hand's boxes allow together: when
    the hand's box alone giving way is enough, the joints' boxes hold (their limits are the ones
    a robot's controller enforces on a joint command) and the hand's rows are relaxed by least
    squares (quadprog's two stages with only those soft); when it is not, both give way (the
    same with the joints' rows soft too). Both count as giving up smoothness."""
    rng = np.random.default_rng(48)
    tested = {"hand": 0, "hand and joints": 0}
    for k in range(600):
        nv = int(rng.integers(4, 8))
        J, B, q0 = task(rng, nv)
        q_prev = rng.uniform(-0.5, 0.5, nv)
        found = hard_problem(rng, nv, q_prev, q_prev)
        u_prev = J @ q_prev
        for r in range(3):
            width = rng.uniform(0.005, 0.1)
            found.append((HAND, J[r], u_prev[r] - width))
            found.append((HAND, -J[r], -u_prev[r] - width))
        a = rng.normal(size=nv)
        found.append((LIMITATION, a, a @ q_prev + rng.uniform(0.05, 1.0)))
        N, b, group, count = rows(found, nv)
        try:
            filter_qp(q0, B, N[:count], b[:count])
            continue  # every row holds: not this test's case
        except ValueError:
            pass
        # Which case: can every row but the hand's (and the plan's) hold? (scipy's LP; margins
        # within 1e-7 of the boundary are left out: either answer is right there.)
        keep = ~np.isin(group[:count], (PLAN, HAND))
        margin = scipy.optimize.linprog(np.r_[np.zeros(nv), -1.0],
                                        A_ub=np.hstack([-N[:count][keep], np.ones((keep.sum(), 1))]),
                                        b_ub=-b[:count][keep], bounds=[(None, None)] * nv + [(None, 1.0)],
                                        method="highs")
        if not margin.success or abs(margin.x[-1]) < 1e-7:
            continue
        case = "hand" if margin.x[-1] > 0 else "hand and joints"
        soft = np.isin(group[:count], (PLAN, HAND) if case == "hand" else (PLAN, HAND, MOTION))
        try:
            expected, violation_qp = lexicographic_qp(q0, B, N[:count], b[:count], soft)
        except ValueError:
            continue  # beyond the speed limits too (another level), or quadprog's degenerate vertex
        qdot, violation, level, _ = filtered(q0, B, N.copy(), b.copy(), group.copy(), count, J, NO_CAP, NO_CAP)
        assert level == LEVEL_SMOOTHNESS, (k, case)
        # (Stage 1's optimum as in the test above; here the violations are larger, and the two
        # solvers' objectives agree to 1e-4 relative: seed 48's worst 2.3e-5.)
        assert_reaches_stage1_optimum(q0, B, N[:count], b[:count], violation[:count], violation_qp, 1e-4, (k, case))
        hair = acceptance(b[:count])
        np.testing.assert_allclose(qdot, expected, rtol=0, atol=1e-3)
        joints = group[:count] == MOTION
        if case == "hand":  # the joints' boxes held
            assert np.all(N[:count][joints] @ qdot >= b[:count][joints] - hair), k
            assert violation[:count][joints].max() == 0.0
        tested[case] += 1
    assert min(tested.values()) > 40, tested


def test_a_recovery_gives_way_before_the_motion_limits():
    """A limitation the arm is inside, drifting out (``RECOVERY``) faster than the motion box
    allows, on problems where the whole retreat agrees with the other hard rows once the box
    gives way (else the retreats contradict: another level). The motion box holds (level exact)
    while the retreat gives way to its ``ramp`` (what it can grow to this step; half the cases)
    or, beyond the box too, to approach nothing (quadprog's QP with the row at that bound);
    when even approaching nothing is beyond the box, the motion rows give way for that only
    (by least squares: quadprog's two stages). How far the box lets the arm out decides which
    (scipy's LP). The same row as ``LIMITATION`` gives up smoothness instead (what the level
    assertion catches when the group is ignored)."""
    rng = np.random.default_rng(47)
    tested = {"ramp": 0, "approach nothing": 0, "smoothness": 0}
    for k in range(800):
        nv = int(rng.integers(3, 8))
        J, B, q0 = task(rng, nv)
        q_prev = rng.uniform(-0.5, 0.5, nv)
        found = hard_problem(rng, nv, q_prev, q_prev)
        a = rng.normal(size=nv)
        if k % 2 == 0:  # approaching nothing is within the box (q_prev itself does not approach)
            a *= np.sign(a @ q_prev) or 1.0
        else:  # the arm approaches it now by more than the box can take back
            a *= -(np.sign(a @ q_prev) or 1.0)
        retreat = abs(a @ q_prev) + rng.uniform(0.5, 2.0)
        found.append((RECOVERY, a, retreat))
        N, b, group, count = rows(found, nv)
        ramp = np.zeros(len(b))
        if k % 4 < 2:
            ramp[count - 1] = rng.uniform(0.0, abs(a @ q_prev) + 0.1)
        try:
            filter_qp(q0, B, N[:count], b[:count])
            continue  # the box is wide enough for the whole retreat: nothing gives way
        except ValueError:
            pass
        try:  # does the retreat agree with the other hard rows when the motion box gives way?
            lexicographic_qp(q0, B, N[:count], b[:count], group[:count] == MOTION)
        except ValueError:  # no: the retreats contradict (the relaxed level's case)
            continue
        # How far the arm can go out of it within the box (every other row hard).
        others = np.arange(count - 1)
        lp = scipy.optimize.linprog(-a, A_ub=-N[others], b_ub=-b[others], bounds=(None, None), method="highs")
        out = -lp.fun
        if not lp.success or min(abs(out), abs(out - ramp[count - 1])) < 1e-6:
            continue  # borderline: either answer is right
        eased = b[:count].copy()
        if out > ramp[count - 1] > 0.0:
            case, eased[-1] = "ramp", ramp[count - 1]
        elif out > 0.0:
            case, eased[-1] = "approach nothing", 0.0
        else:
            case, eased[-1] = "smoothness", 0.0
        try:
            if case == "smoothness":
                expected, violation_qp = lexicographic_qp(q0, B, N[:count], eased, group[:count] == MOTION)
            else:
                expected, violation_qp = filter_qp(q0, B, N[:count], eased), np.zeros(count)
        except ValueError:  # quadprog gives up on a degenerate vertex (narrow boxes)
            continue
        violation_qp[-1] = retreat - eased[-1]
        qdot, violation, level, _ = filtered(q0, B, N.copy(), b.copy(), group.copy(), count, J, NO_CAP, NO_CAP,
                                             ramp=ramp)
        assert level == (LEVEL_SMOOTHNESS if case == "smoothness" else LEVEL_EXACT), (k, case)
        np.testing.assert_allclose(violation[:count], violation_qp, rtol=0, atol=1e-5)
        np.testing.assert_allclose(qdot, expected, rtol=0, atol=1e-4)
        assert a @ qdot >= eased[-1] - 1e-6 * retreat  # never deeper; out at the ramp when it can
        if level == LEVEL_EXACT:  # within the motion box
            motion = group[:count] == MOTION
            assert np.all(N[:count][motion] @ qdot >= b[:count][motion] - 1e-6)
        tested[case] += 1
        group_hard = group.copy()
        group_hard[count - 1] = LIMITATION
        _, _, level_hard, _ = filtered(q0, B, N.copy(), b.copy(), group_hard, count, J, NO_CAP, NO_CAP)
        assert level_hard != LEVEL_EXACT
    assert min(tested.values()) > 40, tested  # seed 47: 133, 145 and 49


def test_nothing_binds_gives_the_command_exactly():
    rng = np.random.default_rng(43)
    for _ in range(500):
        nv = int(rng.integers(3, 8))
        J, B, q0 = task(rng, nv)
        found = hard_problem(rng, nv, q0, q0)
        found = [(g, a, min(x, a @ q0)) for g, a, x in found]  # every row holds at q0
        N, b, group, count = rows(found, nv)
        qdot, violation, level, used = filtered(q0, B, N, b, group, count, J, 10.0, 10.0)
        np.testing.assert_array_equal(qdot, q0)
        assert level == LEVEL_EXACT and used == count and not violation.any()


def test_in_2d_with_hard_limits_it_is_paper_1s_rule():
    """A 2-DOF arm, ``B = M`` (no redundancy): the command ``u`` the filter keeps is the one
    paper 1 (section III.A) slides to, on the limitations mapped into the command's space."""
    rng = np.random.default_rng(44)
    for _ in range(3000):
        M = rng.normal(size=(2, 2))
        if abs(np.linalg.det(M)) < 0.1:
            continue
        v = rng.normal(size=2)
        limitations = rng.normal(size=(int(rng.integers(1, 3)), 2))  # at most two, as the paper
        N, b, group, count = rows([(LIMITATION, a, 0.0) for a in limitations], 2)
        qdot, _, level, _ = filtered(M @ v, M, N, b, group, count, np.zeros((3, 2)), NO_CAP, NO_CAP)
        unit = limitations @ M
        unit /= np.linalg.norm(unit, axis=1, keepdims=True)
        if len(unit) == 2 and unit[0] @ unit[1] < -1.0 + 1e-6:
            continue  # a sliver of a wedge: its apex is ill-conditioned (errors ~ eps / angle^2)
        np.testing.assert_allclose(np.linalg.solve(M, qdot), paper_rule_2d(v, unit), rtol=0, atol=1e-9)


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.3, -2.0, 0.7)])
def test_the_speed_cap_is_a_norm(direction):
    """A straight and a diagonal command are capped to the same speed (a cap per axis lets a
    diagonal run sqrt(3) faster); on a redundant arm too (the cap's tangent planes)."""
    cap = 0.25
    u = np.array(direction) / np.linalg.norm(direction)
    N, b, group, count = rows([], 3)
    qdot, _, _, used = filtered(2.0 * cap * u, np.eye(3), N, b, group, count, np.eye(3), cap, 2.0 * cap)
    assert np.linalg.norm(qdot) == pytest.approx(cap, rel=1e-9)
    np.testing.assert_allclose(qdot / np.linalg.norm(qdot), u, atol=1e-9)  # straight down the command
    assert used == 1
    rng = np.random.default_rng(45)
    for _ in range(200):
        J, B, _ = task(rng, 7)
        q0 = np.linalg.pinv(J) @ (3.0 * cap * u)
        N, b, group, count = rows([], 7)
        qdot, _, _, _ = filtered(q0, B, N, b, group, count, J, cap, 2.0 * cap)
        assert np.linalg.norm(J @ qdot) == pytest.approx(cap, rel=1e-6)


def test_contradicting_retreats_are_relaxed_down_to_approaching_nothing():
    """Two retreats no command meets at once within the speed limits: each gives way by least
    squares, but never so far that the arm approaches the limitation (``a . qdot >= 0``)."""
    rng = np.random.default_rng(46)
    done = 0
    for _ in range(300):
        nv = int(rng.integers(3, 8))
        J, B, q0 = task(rng, nv)
        a = rng.normal(size=nv)
        found = [(LIMITATION, a, rng.uniform(0.5, 1.0) * 2 * np.abs(a).sum()),
                 (LIMITATION, -a + 0.1 * rng.normal(size=nv), rng.uniform(0.5, 1.0) * 2 * np.abs(a).sum())]
        for j in range(nv):
            for sign in (1.0, -1.0):
                e = np.zeros(nv)
                e[j] = sign
                found.append((VELOCITY, e, -2.0))
        N, b, group, count = rows(found, nv)
        qdot, violation, level, _ = filtered(q0, B, N.copy(), b.copy(), group.copy(), count, J, NO_CAP, NO_CAP)
        if level != LEVEL_RELAXED:
            continue
        # Approach nothing, within the speed limits: to relax_kernel's acceptance (1e-6 of the
        # bounds' size; the relaxed levels solve two stacked least-distance problems).
        assert np.all(N[:2] @ qdot >= -1e-6)
        assert np.all(np.abs(qdot) <= 2.0 + 2e-6)
        assert np.all(violation[:2] > 0.0)
        done += 1
    assert done > 100


def test_the_cap_ahead_against_the_exact_second_order_cone_problem():
    """``filter_rows`` with ``lead`` != 0 against the same problem with both balls written
    exactly (``ahead_cap_qp``: scipy's SLSQP on ``min ||z||^2`` s.t. the rows and the two
    second-order cones). Random arms (``task``), the command 2-4 times the cap (0.25 m/s), the
    hand's previous velocity ``ee_prev`` 0.6-1 times it, ``lead`` in [1, 30] per axis, all
    directions random. Half the problems have only the joints' speed limits ("far": the kernel
    starts far from the cap ahead), half add the hand's motion box, +-0.6-3 % of the cap per axis
    around ``ee_prev`` ("near": as the controller's step keeps the hand, with a box far
    narrower at 2 ms).

    Always, to the oracle's precision (SLSQP meets the balls to 3.7e-8 of the cap, seeds
    48-50; scipy 1.17.1 on an AVX-512 EPYC to 1.5e-7, problem 113 of seed 48): every tangent
    plane the kernel adds holds at the exact optimum (an outer approximation: worst miss
    9.2e-9), so the kernel's objective is no worse than the optimum
    (worst 4.2e-10 above it, relative), which is no worse than the kernel's answer pulled toward
    a point inside both balls until it meets them (a feasible point: the optimum at most
    1.4e-13 above it, rounding); and
    ``||z - z*||^2 <= f* - f(z)`` (``||z||^2`` is strongly convex on the kernel's polytope, which
    holds ``z*``).

    What the ``SPEED_CUTS`` (8) cuts leave, seed 48. "Near": 133 of 150 end inside both balls
    (to the kernel's 1e-9), then at the oracle's answer to 1.3e-5 rad/s (SLSQP's precision at
    ftol 1e-13: its distance to its own answer polished by Newton on its active set); the worst
    ends 0.73 % over the cap ahead. "Far": all 150 use the 8 cuts and end over the cap ahead, by
    up to 40 times the cap, their objective up to 72 % under the optimum: the loop cuts the
    speed ball whenever it is over by 1e-9 (an ahead cut can push the answer out of it again,
    and through the rows its cuts close in slowly), so only 408 of the 1200 cuts are ahead cuts
    (21 problems get none), and the ahead ball, stretched by ``1 + lead``, takes many. (Cutting
    instead the ball exceeded most relative to its cap: 0.09 times the cap at worst, measured.)
    The bounds on the excess are these figures, not the kernel's promise. The cap ahead alone
    decides the optimum (on its sphere, the speed ball slack) in all 150 "far" problems and 58
    "near"."""
    rng = np.random.default_rng(48)
    cap = 0.25
    counted = {"far": 0, "near": 0, "near, inside both balls": 0}
    worst_excess = {"far": 0.0, "near": 0.0}
    for k in range(300):
        regime = "near" if k % 2 else "far"
        J, B, q0 = task(rng, 7)
        q0 *= rng.uniform(2.0, 4.0) * cap / np.linalg.norm(J @ q0)
        ee_prev = rng.normal(size=3)
        ee_prev *= rng.uniform(0.6, 1.0) * cap / np.linalg.norm(ee_prev)
        lead = rng.uniform(1.0, 30.0, 3)
        # A joint velocity inside both balls and the rows: the hand's previous velocity, or the
        # centre of the cap ahead (``ahead`` = 0).
        inside = np.linalg.pinv(J) @ (ee_prev if regime == "near" else lead / (1.0 + lead) * ee_prev)
        found = []
        for j in range(7):
            for sign in (1.0, -1.0):
                e = np.zeros(7)
                e[j] = sign
                found.append((VELOCITY, e, -(abs(inside[j]) + rng.uniform(0.05, 0.5))))
        if regime == "near":
            for r in range(3):
                for sign in (1.0, -1.0):
                    found.append((MOTION, sign * J[r], sign * ee_prev[r] - rng.uniform(0.2, 1.0) * 0.03 * cap))
        N, b, group, count = rows(found, 7)
        N_cut, b_cut = N.copy(), b.copy()  # the kernel writes its cuts after ``count``
        qdot, violation, level, used = filter_rows(q0, B, N_cut, b_cut, np.zeros(len(b)), group.copy(), count, J,
                                                   cap, 4.0 * cap, ee_prev, lead, cap)
        assert level == LEVEL_EXACT and not violation.any(), (k, level)
        expected = ahead_cap_qp(q0, B, N[:count], b[:count], J, cap, ee_prev, lead, cap, inside)

        def over(q):  # (speed, speed ahead) / cap - 1
            u = J @ q
            return np.array([np.linalg.norm(u), np.linalg.norm(u + lead * (u - ee_prev))]) / cap - 1.0

        z, z_exact = np.linalg.solve(B, qdot - q0), np.linalg.solve(B, expected - q0)
        excess = np.maximum(over(qdot), 0.0)
        t = float(np.max(excess / (excess - over(inside))))  # norms are convex in z
        z_pulled = (1.0 - t) * z + t * np.linalg.solve(B, inside - q0)
        reached, optimum, pulled = z @ z, z_exact @ z_exact, z_pulled @ z_pulled
        assert np.all(over(expected) <= 2e-7) and np.all(N[:count] @ expected >= b[:count] - 1e-9), k
        assert np.all(N_cut[count:used] @ expected >= b_cut[count:used] - 1e-7), k  # outer approximation
        assert reached <= optimum * (1.0 + 1e-8), (k, reached, optimum)
        assert optimum <= pulled * (1.0 + 1e-9), (k, optimum, pulled)
        assert np.sum((z - z_exact) ** 2) <= optimum - reached + 1e-8 * optimum, k
        worst_excess[regime] = max(worst_excess[regime], float(excess.max()))
        if regime == "near" and excess.max() <= 1e-9:
            np.testing.assert_allclose(qdot, expected, rtol=0, atol=5e-5)
            counted["near, inside both balls"] += 1
        counted[regime] += bool(over(expected)[1] > -1e-6 and over(expected)[0] < -1e-6)
    assert worst_excess["near"] <= 0.01 and worst_excess["far"] <= 50.0, worst_excess
    assert counted["far"] > 120 and counted["near"] > 40 and counted["near, inside both balls"] > 110, counted
