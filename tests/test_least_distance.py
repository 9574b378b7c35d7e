"""The compiled solver itself (``cobotsafety.least_distance``), called directly: ``slide_kernel``
and ``relax_kernel`` against quadprog with their status codes, overflow-safe scaling, and the
check of its own answer (``slide`` never hands out a result that misses a row)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cobotsafety import least_distance
from cobotsafety.errors import InfeasibleConstraintsError
from cobotsafety.least_distance import (FEASIBILITY_TOLERANCE, INFEASIBLE, NOT_MET, RELAX_DONE,
                                        RELAX_HARD_CONTRADICT, RELAX_STAGE_INFEASIBLE, RELAXATION_COMMAND_WEIGHT,
                                        SOLVED, ZERO_ROW_INFEASIBLE, relax_kernel, slide_kernel)
from cobotsafety.projection import slide
from oracles.projection import kkt_residual, quadprog_projection, quadprog_relaxation


def feasible_problem(rng: np.random.Generator):
    """Rows of any scale through a random feasible point (so quadprog agrees it is feasible)."""
    n, m = int(rng.integers(1, 8)), int(rng.integers(1, 20))
    normals = rng.normal(size=(m, n)) * 10.0 ** rng.uniform(-2, 2, size=(m, 1))
    x0 = rng.normal(size=n)
    bounds = normals @ x0 - np.abs(rng.normal(size=m)) * rng.integers(0, 2, size=m)
    return rng.normal(size=n) * 3.0, normals, bounds


def test_slide_kernel_matches_quadprog_and_reports_its_status():
    rng = np.random.default_rng(31)
    worst, compared = 0.0, 0
    for _ in range(3000):
        v, N, b = feasible_problem(rng)
        x, status, _ = slide_kernel(v, N, b)
        assert status == SOLVED
        assert np.all(N @ x >= b - 1e-9 * (1.0 + np.abs(N).sum(axis=1) * (1.0 + np.abs(x).max())))
        try:
            expected = quadprog_projection(v, N, b)
        except ValueError:  # quadprog gives up on some degenerate active sets: the KKT conditions
            scale = np.abs(N).sum(axis=1, keepdims=True)
            assert kkt_residual(x, v, N / scale, b / scale[:, 0]) <= 1e-9
            continue
        worst = max(worst, float(np.max(np.abs(x - expected))))
        compared += 1
    assert worst <= 1e-9 and compared >= 2500
    # Nothing violated: the command itself, a copy.
    v = np.array([1.0, 2.0])
    x, status, _ = slide_kernel(v, np.array([[1.0, 0.0]]), np.array([0.5]))
    assert status == SOLVED and np.array_equal(x, v) and x is not v
    # No rows at all.
    x, status, _ = slide_kernel(v, np.zeros((0, 2)), np.zeros(0))
    assert status == SOLVED and np.array_equal(x, v)


def test_slide_kernel_status_codes_for_contradictions_zero_rows_and_inactive_rows():
    # x >= 1 and -x >= 1: the unit rows' largest violation at v = 0 is 1.
    x, status, advance = slide_kernel(np.zeros(2), np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 1.0]))
    assert status == INFEASIBLE and advance == pytest.approx(1.0) and np.array_equal(x, np.zeros(2))
    x, status, _ = slide_kernel(np.zeros(2), np.zeros((1, 2)), np.array([0.5]))
    assert status == ZERO_ROW_INFEASIBLE
    x, status, _ = slide_kernel(np.array([-1.0, 0.0]), np.zeros((1, 2)), np.array([-0.5]))  # 0 >= -0.5 holds
    assert status == SOLVED and np.array_equal(x, [-1.0, 0.0])
    # A bound of -inf makes its row inactive: the same answer as without the row.
    rng = np.random.default_rng(32)
    for _ in range(200):
        v, N, b = feasible_problem(rng)
        off = rng.uniform(size=len(b)) < 0.3
        x_inf, status, _ = slide_kernel(v, N, np.where(off, -np.inf, b))
        assert status == SOLVED
        x_drop, _, _ = slide_kernel(v, np.ascontiguousarray(N[~off]), np.ascontiguousarray(b[~off]))
        np.testing.assert_allclose(x_inf, x_drop, rtol=0, atol=1e-12)


def contradicting_retreats(rng):
    """Hard rows admitting zero, and retreats (bounds > 0) that contradict each other."""
    n = 3
    while True:
        hard = rng.normal(size=(int(rng.integers(0, 5)), n))
        base = rng.normal(size=n)
        retreats = np.vstack([base, -base + 0.4 * rng.normal(size=n), rng.normal(size=(int(rng.integers(0, 3)), n))])
        box = np.vstack([np.eye(n), -np.eye(n)])
        N = np.vstack([hard, retreats, box])
        b = np.concatenate([-rng.uniform(0.05, 1.0, len(hard)), rng.uniform(0.05, 1.0, len(retreats)), np.full(2 * n, -0.5)])
        v = rng.normal(size=n) * 0.5
        if slide_kernel(v, N, b)[1] == INFEASIBLE:
            return v, N, b


def test_relax_kernel_matches_the_two_stage_quadprog_and_reports_its_status():
    rng = np.random.default_rng(33)
    for k in range(300):
        v, N, b = contradicting_retreats(rng)
        soft = b > 0.0
        floors = np.where(soft, 0.0, -np.inf) if k % 2 else np.full(len(b), -np.inf)
        x, violation, status, rows, _ = relax_kernel(v, N, b, soft, floors, RELAXATION_COMMAND_WEIGHT)
        assert status == RELAX_DONE and rows == 0
        x_qp, violation_qp = quadprog_relaxation(v, N, b, soft, floors)
        np.testing.assert_allclose(violation, violation_qp, rtol=0, atol=1e-7)
        np.testing.assert_allclose(x, x_qp, rtol=0, atol=1e-6)
        assert np.all(violation[~soft] == 0.0)
        assert np.all(N @ x >= b - violation - 1e-9)
    # Feasible rows: the plain slide, nothing relaxed.
    v, N, b = feasible_problem(rng)
    x, violation, status, _, _ = relax_kernel(v, N, b, np.ones(len(b), dtype=np.bool_), np.full(len(b), -np.inf),
                                              RELAXATION_COMMAND_WEIGHT)
    assert status == RELAX_DONE and not violation.any()
    np.testing.assert_array_equal(x, slide_kernel(v, N, b)[0])
    # Nothing soft: the hard rows contradict, all m of them reported.
    N, b = np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 1.0])
    _, _, status, rows, _ = relax_kernel(np.zeros(2), N, b, np.zeros(2, dtype=np.bool_), np.full(2, -np.inf), 0.01)
    assert status == RELAX_HARD_CONTRADICT and rows == 2
    # A soft row whose floor contradicts a hard row: the stage is infeasible.
    _, _, status, rows, advance = relax_kernel(np.zeros(2), N, b, np.array([False, True]), np.array([-np.inf, 0.5]), 0.01)
    assert status == RELAX_STAGE_INFEASIBLE and rows == 3 and advance > 0.0


def test_huge_and_tiny_rows_and_commands_never_give_a_wrong_answer():
    """Normals of 1e200 (and 1e-200) beside ordinary ones, commands of 1e300: the result meets
    every row and equals the scaled-down problem's (the projection is positively homogeneous
    in the command and the bounds, and invariant to each row's scale), or the rows are
    reported contradictory. Never an overflow, a NaN or an answer that misses a row."""
    rng = np.random.default_rng(34)
    solved = refused = 0
    for k in range(400):
        v0, N0, b0 = feasible_problem(rng)
        if k % 4 == 3:  # contradicting rows: only an error may come out
            N0 = np.vstack([N0, -N0[:1]])
            b0 = np.append(b0, -b0[0] + 1.0)
        m = len(b0)
        row_scale = 10.0 ** rng.choice([-200.0, 0.0, 150.0, 200.0], size=m)
        s = 10.0 ** rng.choice([0.0, 100.0, 300.0])  # the command's and the bounds' scale
        N, v = N0 * row_scale[:, None], v0 * s
        with np.errstate(over="ignore"):
            b = b0 * s * row_scale
        finite = np.isfinite(b) & (np.abs(b) < 1e300)
        if not finite.all():  # a bound beyond float range: drop that case
            continue
        try:
            x = slide(v, N, b)
        except InfeasibleConstraintsError:
            refused += 1
            assert k % 4 == 3 or slide_kernel(v0, N0, b0)[1] != SOLVED
            continue
        assert np.all(np.isfinite(x))
        scaled = x / s
        assert np.all(N0 @ scaled >= b0 - 1e-9 * (1.0 + np.abs(N0).sum(axis=1) * (1.0 + np.abs(scaled).max())))
        expected, status, _ = slide_kernel(v0, N0, b0)
        assert status == SOLVED
        np.testing.assert_allclose(scaled, expected, rtol=1e-9, atol=1e-9 * (1.0 + np.abs(expected).max()))
        solved += 1
    assert solved > 100 and refused > 30


@pytest.fixture
def wrong_solver(monkeypatch):
    """The solver's inner loop replaced by one that returns a point missing the rows, with the
    kernel run as Python (its source is the specification): the final check must catch it."""
    def wrong(G, h, tol):
        return np.zeros(G.shape[1]) - 1.0, True

    monkeypatch.setattr(least_distance, "_dual_active_set", wrong)
    python_kernel = getattr(slide_kernel, "py_func", slide_kernel)
    monkeypatch.setattr("cobotsafety.projection.slide_kernel", python_kernel)
    return python_kernel


def test_slide_checks_its_result_before_handing_it_out(wrong_solver):
    N, b = np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([0.5, 0.5])
    _, status, _ = wrong_solver(np.zeros(2), N, b)
    assert status == NOT_MET
    with pytest.raises(InfeasibleConstraintsError, match="misses a half-space"):
        slide(np.zeros(2), N, b)


def test_the_active_set_never_holds_more_rows_than_dimensions():
    """Unit rows from the arm's step (panda beside a person, ``bench arm``'s human step; 67 rows
    in 7 dimensions, boxes of nearly opposite rows): seven rows active span every direction, and
    an eighth violated row is in their span up to rounding (``|z|^2`` ~ 1e-23). Its full step
    was taken before (``t = -s / |z|^2``, an answer of 1e12) and made an eighth then a ninth
    active row: the Python source raised IndexError, the compiled code wrote past its array."""
    data = np.load(Path(__file__).parent / "data" / "least_distance" / "full_rank_active_set.npz")
    G, h = data["G"], data["h"]
    for tol in (1e-12, FEASIBILITY_TOLERANCE):
        x_source, ok_source = least_distance._dual_active_set.py_func(G.copy(), h.copy(), tol)
        x, ok = least_distance._dual_active_set(G.copy(), h.copy(), tol)
        assert ok == ok_source and np.allclose(x, x_source, rtol=0.0, atol=1e-12)
        assert np.max(np.abs(x)) < 1.0  # the least-norm point of rows with bounds < 0.6
    # The tolerance the slide falls back to solves it: every row met, and the least-norm point.
    x, ok = least_distance._dual_active_set(G.copy(), h.copy(), FEASIBILITY_TOLERANCE)
    assert ok and np.all(G @ x >= h - FEASIBILITY_TOLERANCE)
    assert kkt_residual(x, np.zeros(G.shape[1]), G, h, active_tol=1e-8) <= 1e-8
