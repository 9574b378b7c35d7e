"""The sliding projection against independent oracles: quadprog, the paper's 2D rule, invariants."""

from __future__ import annotations

import logging
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.optimize import lsq_linear

from cobotsafety import slide
from cobotsafety.errors import InfeasibleConstraintsError
from oracles.projection import paper_rule_2d, quadprog_projection


def random_problem(rng: np.random.Generator, feasible_at_zero: bool):
    n = int(rng.integers(1, 7))
    m = int(rng.integers(1, 16))
    v_desired = rng.normal(size=n)
    normals = rng.normal(size=(m, n)) * rng.uniform(0.1, 3.0, size=(m, 1))
    if feasible_at_zero:
        bounds = -np.abs(rng.normal(size=m)) * rng.integers(0, 2, size=m)
    else:
        # Feasible by construction: every half-space contains a random point x0.
        x0 = rng.normal(size=n)
        bounds = normals @ x0 - np.abs(rng.normal(size=m))
    return v_desired, normals, bounds


def assert_kkt_optimal(v, v_desired, normals, bounds):
    """Optimality certificate: feasible, and v - v_desired = normals_active^T lambda, lambda >= 0."""
    slack = normals @ v - bounds
    assert np.all(slack >= -1e-9)
    active = slack <= 1e-9
    fit = lsq_linear(normals[active].T, v - v_desired, bounds=(0.0, np.inf), method="bvls", tol=1e-14)
    assert np.max(np.abs(normals[active].T @ fit.x - (v - v_desired))) <= 1e-9


def test_matches_quadprog_on_ten_thousand_random_problems():
    rng = np.random.default_rng(20161009)
    worst = 0.0
    quadprog_failures = 0
    for k in range(10_000):
        v_desired, normals, bounds = random_problem(rng, feasible_at_zero=k % 2 == 0)
        got = slide(v_desired, normals, bounds)
        try:
            expected = quadprog_projection(v_desired, normals, bounds)
        except ValueError:
            # quadprog gives up on some degenerate active sets of these feasible problems;
            # there the KKT conditions certify the answer instead.
            quadprog_failures += 1
            assert_kkt_optimal(got, v_desired, normals, bounds)
            continue
        worst = max(worst, float(np.max(np.abs(got - expected))))
    assert worst <= 1e-9
    assert quadprog_failures < 100


def test_three_constraints_in_3d_slide_along_an_edge_and_into_a_corner():
    # Two walls meeting along the z axis: the command slides along the edge.
    normals = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    v = slide(np.array([-1.0, -2.0, 0.5]), normals)
    np.testing.assert_allclose(v, [0.0, 0.0, 0.5], atol=1e-15)
    # A third, oblique wall closes the corner from above: only zero is left.
    normals3 = np.vstack([normals, [0.0, 0.0, -1.0]])
    np.testing.assert_allclose(slide(np.array([-1.0, -2.0, 0.5]), normals3), 0.0, atol=1e-15)
    # Oblique walls: compare the edge solution with quadprog.
    rng = np.random.default_rng(3)
    for _ in range(1000):
        normals = rng.normal(size=(3, 3))
        v_desired = -normals.sum(axis=0) + rng.normal(size=3) * 0.3
        np.testing.assert_allclose(
            slide(v_desired, normals), quadprog_projection(v_desired, normals, np.zeros(3)), atol=1e-9
        )


def test_agrees_with_the_papers_rule_in_2d():
    rng = np.random.default_rng(2)
    for _ in range(10_000):
        m = int(rng.integers(1, 3))  # the paper's claim: at most two limitations in 2D
        angles = rng.uniform(0, 2 * np.pi, size=m)
        unit_normals = np.column_stack([np.cos(angles), np.sin(angles)])
        v_desired = rng.normal(size=2)
        np.testing.assert_allclose(slide(v_desired, unit_normals), paper_rule_2d(v_desired, unit_normals), atol=1e-9)


def test_no_constraint_returns_a_copy():
    v_desired = np.array([1.0, 2.0, 3.0])
    for normals in (np.zeros((0, 3)), []):
        v = slide(v_desired, normals)
        assert v is not v_desired
        np.testing.assert_array_equal(v, v_desired)


def test_single_constraint_keeps_the_tangential_component_exactly():
    rng = np.random.default_rng(5)
    for _ in range(1000):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        v_desired = rng.normal(size=3)
        v = slide(v_desired, n[None, :])
        tangential_desired = v_desired - (v_desired @ n) * n
        tangential = v - (v @ n) * n
        np.testing.assert_allclose(tangential, tangential_desired, atol=1e-15)
        assert v @ n == pytest.approx(max(v_desired @ n, 0.0), abs=1e-15)


finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)


@st.composite
def problems(draw):
    n = draw(st.integers(1, 4))
    m = draw(st.integers(0, 6))
    v_desired = draw(arrays(float, (n,), elements=finite))
    normals = draw(arrays(float, (m, n), elements=finite))
    bounds = -np.abs(draw(arrays(float, (m,), elements=finite)))  # v = 0 always feasible
    return v_desired, normals, bounds


def violates_exactly(normals, bounds, v) -> bool:
    """Whether ``v`` breaks a row, in exact rational arithmetic (floating-point ``normals @ v``
    underflows to 0 for subnormal normals, so it can call a violated row met)."""
    return any(sum(Fraction(float(a)) * Fraction(float(x)) for a, x in zip(row, v)) < Fraction(float(b))
               for row, b in zip(normals, bounds))


@settings(max_examples=400, deadline=None)
@given(problems())
@example((np.array([0.5]), np.array([[-5e-324]]), np.array([-0.0])))  # subnormal normal: -2.5e-324 < 0
def test_properties(problem):
    v_desired, normals, bounds = problem
    v = slide(v_desired, normals, bounds)
    scale = 1.0 + np.abs(normals).sum(axis=1) * (1.0 + np.abs(v_desired).max())
    # Satisfies every constraint.
    assert np.all(normals @ v - bounds >= -1e-9 * scale)
    # Unchanged when nothing is violated.
    if not violates_exactly(normals, bounds, v_desired):
        np.testing.assert_array_equal(v, v_desired)
    # Idempotent.
    np.testing.assert_allclose(slide(v, normals, bounds), v, atol=1e-9 * scale.max(initial=1.0))
    # Never farther than the always-feasible zero command.
    assert np.linalg.norm(v - v_desired) <= np.linalg.norm(v_desired) + 1e-9


def test_infeasible_bounds_raise_a_clear_error():
    n = np.array([[1.0, 0.0], [-1.0, 0.0]])
    with pytest.raises(InfeasibleConstraintsError, match="contradict"):
        slide(np.zeros(2), n, np.array([1.0, 1.0]))
    with pytest.raises(InfeasibleConstraintsError, match="zero normal"):
        slide(np.zeros(2), np.zeros((1, 2)), np.array([0.5]))


def test_non_finite_desired_velocity_gives_zero_and_a_warning(caplog):
    with caplog.at_level(logging.WARNING):
        v = slide(np.array([np.nan, 1.0]), np.array([[1.0, 0.0]]))
    np.testing.assert_array_equal(v, [0.0, 0.0])
    assert "NaN" in caplog.text
    v = slide(np.array([np.inf, 1.0]), np.array([[1.0, 0.0]]), np.array([0.5]))
    np.testing.assert_allclose(v, [0.5, 0.0])


@pytest.mark.parametrize(
    ("args", "argument"),
    [
        ((np.zeros((2, 2)), np.zeros((1, 2))), "v_desired"),
        ((np.zeros(2), np.zeros((1, 3))), "normals"),
        ((np.zeros(2), np.zeros((2, 2)), np.zeros(3)), "bounds"),
        ((np.zeros(2), np.array([[np.nan, 1.0]])), "normals"),
    ],
)
def test_wrong_input_names_the_argument(args, argument):
    with pytest.raises(ValueError, match=argument):
        slide(*args)
