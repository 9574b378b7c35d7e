"""``relax``: the least-squares relaxation of contradicting half-spaces, against quadprog with slacks."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety import slide
from cobotsafety.errors import InfeasibleConstraintsError
from cobotsafety.projection import relax
from oracles.projection import quadprog_relaxation


def infeasible_problem(rng):
    """Hard rows admitting v = 0 (bounds <= 0) and retreats (bounds > 0) that contradict."""
    n = 3
    hard = rng.normal(size=(int(rng.integers(0, 6)), n))
    hard_bounds = -rng.uniform(0.05, 1.0, size=hard.shape[0])
    base = rng.normal(size=n)
    retreats = [base, -base + 0.5 * rng.normal(size=n)]  # nearly opposite: they contradict
    retreats += list(rng.normal(size=(int(rng.integers(0, 3)), n)))
    retreats = np.array(retreats)
    retreat_bounds = rng.uniform(0.05, 1.0, size=len(retreats))
    # The arm's speed box, as in the step.
    box = np.vstack([np.eye(n), -np.eye(n)])
    normals = np.vstack([hard, retreats, box])
    bounds = np.concatenate([hard_bounds, retreat_bounds, np.full(2 * n, -0.5)])
    v_desired = rng.normal(size=n) * 0.5
    try:
        slide(v_desired, normals, bounds)
    except InfeasibleConstraintsError:
        return normals, bounds, v_desired
    return infeasible_problem(rng)  # these happened to agree: draw again


def test_relaxation_matches_a_qp_with_slacks_on_random_infeasible_sets():
    rng = np.random.default_rng(11)
    tested = 0
    while tested < 300:
        normals, bounds, v_desired = infeasible_problem(rng)
        soft = bounds > 0.0
        floor = np.zeros_like(bounds)  # each retreat gives way to "approach nothing" at most
        v, violation = relax(v_desired, normals, bounds, soft, floor)
        v_qp, violation_qp = quadprog_relaxation(v_desired, normals, bounds, soft, floor)
        np.testing.assert_allclose(violation, violation_qp, atol=1e-7)
        np.testing.assert_allclose(v, v_qp, atol=1e-6)
        assert np.all(violation[~soft] == 0.0) and np.any(violation > 0.0)
        hard_rows = ~soft
        assert np.all(normals[hard_rows] @ v >= bounds[hard_rows] - 1e-9)  # the hard rows hold
        assert np.all(normals[soft] @ v >= -1e-9)  # and the floors: no retreat turns into an approach
        assert np.all(normals @ v >= bounds - violation - 1e-9)
        tested += 1


def test_relaxation_without_floors_matches_the_qp_too():
    rng = np.random.default_rng(12)
    tested = 0
    while tested < 200:
        normals, bounds, v_desired = infeasible_problem(rng)
        tested += 1
        soft = bounds > 0.0
        floor = np.full_like(bounds, -np.inf)
        v, violation = relax(v_desired, normals, bounds, soft)
        v_qp, violation_qp = quadprog_relaxation(v_desired, normals, bounds, soft, floor)
        np.testing.assert_allclose(violation, violation_qp, atol=1e-7)
        np.testing.assert_allclose(v, v_qp, atol=1e-6)


def test_feasible_sets_are_plain_slides():
    rng = np.random.default_rng(13)
    for _ in range(200):
        normals = rng.normal(size=(5, 3))
        bounds = -rng.uniform(0.0, 1.0, size=5)
        v_desired = rng.normal(size=3)
        v, violation = relax(v_desired, normals, bounds, bounds > -0.5)
        np.testing.assert_array_equal(v, slide(v_desired, normals, bounds))
        assert np.all(violation == 0.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_command_is_relaxed_as_zero_with_a_warning(bad, caplog):
    """As ``slide``: a NaN or inf command never reaches the solver; the answer is the zero
    command's (finite), and the log says so once."""
    rng = np.random.default_rng(14)
    normals, bounds, _ = infeasible_problem(rng)
    soft = bounds > 0.0  # the retreats give way
    v_bad = np.array([0.1, bad, -0.2])
    with caplog.at_level("WARNING", logger="cobotsafety.projection"):
        v, violation = relax(v_bad, normals, bounds, soft)
    expected, expected_violation = relax(np.zeros(3), normals, bounds, soft)
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(violation))
    np.testing.assert_array_equal(v, expected)
    np.testing.assert_array_equal(violation, expected_violation)
    assert sum("not finite" in r.getMessage() or "NaN or inf" in r.getMessage() for r in caplog.records) == 1


def test_contradicting_hard_rows_still_raise_and_shapes_are_checked():
    normals = np.array([[1.0, 0.0], [-1.0, 0.0]])
    with pytest.raises(InfeasibleConstraintsError):
        relax(np.zeros(2), normals, np.array([1.0, 1.0]), np.array([False, False]))
    with pytest.raises(ValueError, match="soft"):
        relax(np.zeros(2), normals, np.array([1.0, 1.0]), np.array([True]))
