"""capsule_distance against coal (random and every degenerate family), symmetry, witnesses."""

from __future__ import annotations

import math
from fractions import Fraction

import coal
import numpy as np
import pytest

from cobotsafety import capsule_distance
from cobotsafety.geometry.capsule import segment_closest_points


def rotation_z_to(direction: np.ndarray) -> np.ndarray:
    """A rotation matrix taking +z to ``direction`` (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, direction)
    c = float(z @ direction)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx * (1.0 / (1.0 + c))


def coal_shape(p0, p1, radius):
    axis = p1 - p0
    length = np.linalg.norm(axis)
    centre = (p0 + p1) / 2
    if length < 1e-12:
        return coal.Sphere(radius), coal.Transform3s(np.eye(3), centre)
    return coal.Capsule(radius, length), coal.Transform3s(rotation_z_to(axis / length), centre)


def coal_distance(a0, a1, ra, b0, b1, rb) -> float:
    sa, ta = coal_shape(a0, a1, ra)
    sb, tb = coal_shape(b0, b1, rb)
    return coal.distance(sa, ta, sb, tb, coal.DistanceRequest(), coal.DistanceResult())


def degenerate_cases(rng):
    """Parallel, antiparallel, collinear (overlapping and apart), zero-length, crossing, touching."""
    cases = []
    for _ in range(300):
        p = rng.normal(size=3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        offset = np.cross(d, rng.normal(size=3))
        offset *= rng.uniform(0.0, 1.0) / max(np.linalg.norm(offset), 1e-12)
        L1, L2 = rng.uniform(0.1, 1.0, 2)
        shift = rng.uniform(-1.5, 1.5)
        ra, rb = rng.uniform(0.01, 0.2, 2)
        cases += [
            (p, p + L1 * d, ra, p + offset + shift * d, p + offset + (shift + L2) * d, rb),  # parallel
            (p, p + L1 * d, ra, p + offset + (shift + L2) * d, p + offset + shift * d, rb),  # antiparallel
            (p, p + L1 * d, ra, p + shift * d, p + (shift + L2) * d, rb),  # collinear
            (p, p, ra, p + offset, p + offset + L2 * d, rb),  # A is a point
            (p, p + L1 * d, ra, p + offset, p + offset, rb),  # B is a point
            (p, p, ra, p + offset, p + offset, rb),  # two points
        ]
        e = np.cross(d, offset if np.linalg.norm(offset) > 1e-9 else rng.normal(size=3))
        e /= np.linalg.norm(e)
        mid = p + 0.5 * L1 * d
        cases.append((p, p + L1 * d, ra, mid - 0.5 * L2 * e, mid + 0.5 * L2 * e, rb))  # crossing
        cases.append((p, p + L1 * d, ra, p + L1 * d, p + L1 * d + L2 * e, rb))  # sharing an end
    return cases


def random_cases(rng, n):
    return [(rng.normal(size=3), rng.normal(size=3), rng.uniform(0, 0.3), rng.normal(size=3),
             rng.normal(size=3), rng.uniform(0, 0.3)) for _ in range(n)]


def check_against_coal(cases):
    arrays = [np.array([c[i] for c in cases]) for i in range(6)]
    distance, point_a, point_b = capsule_distance(*arrays)
    assert np.all(np.isfinite(distance)) and np.all(np.isfinite(point_a)) and np.all(np.isfinite(point_b))
    expected = np.array([coal_distance(*c) for c in cases])
    # Separated and overlapping alike (coal's capsule-capsule distance is signed too).
    np.testing.assert_allclose(distance, expected, atol=1e-9)
    overlapping = int(np.sum(expected < 0))
    # Witness points lie on their segments and realise the axis distance.
    a0, a1, ra, b0, b1, rb = arrays
    np.testing.assert_allclose(np.linalg.norm(point_a - point_b, axis=-1) - ra - rb, distance, atol=1e-12)
    for p, s0, s1 in ((point_a, a0, a1), (point_b, b0, b1)):
        seg = s1 - s0
        length2 = np.einsum("ij,ij->i", seg, seg)
        t = np.einsum("ij,ij->i", p - s0, seg) / np.where(length2 > 0, length2, 1.0)
        assert np.all((t >= -1e-12) & (t <= 1 + 1e-12))
        np.testing.assert_allclose(s0 + t[:, None] * seg, p, atol=1e-12)
    return overlapping


def test_matches_coal_on_random_capsules():
    assert check_against_coal(random_cases(np.random.default_rng(0), 10_000)) > 500  # some overlap


def test_matches_coal_on_every_degenerate_family():
    assert check_against_coal(degenerate_cases(np.random.default_rng(1))) > 500


def test_overlap_depth_is_exact_when_the_axes_cross():
    d, pa, pb = capsule_distance([0, 0, 0], [1, 0, 0], 0.1, [0.5, -1, 0], [0.5, 1, 0], 0.2)
    assert d == pytest.approx(-0.3)
    np.testing.assert_allclose(pa, [0.5, 0, 0])
    np.testing.assert_allclose(pb, [0.5, 0, 0])


def test_symmetry():
    rng = np.random.default_rng(2)
    a0, a1, b0, b1 = (rng.normal(size=(1000, 3)) for _ in range(4))
    ra, rb = rng.uniform(0, 0.3, (2, 1000))
    d_ab, pa, pb = capsule_distance(a0, a1, ra, b0, b1, rb)
    d_ba, qb, qa = capsule_distance(b0, b1, rb, a0, a1, ra)
    np.testing.assert_allclose(d_ab, d_ba, atol=1e-12)
    np.testing.assert_allclose(pa, qa, atol=1e-9)
    np.testing.assert_allclose(pb, qb, atol=1e-9)


def test_closest_points_are_optimal_by_sampling():
    rng = np.random.default_rng(3)
    s = np.linspace(0, 1, 201)
    for _ in range(50):
        a0, a1, b0, b1 = rng.normal(size=(4, 3))
        pa, pb = segment_closest_points(a0, a1, b0, b1)
        A = a0 + s[:, None] * (a1 - a0)
        B = b0 + s[:, None] * (b1 - b0)
        brute = np.min(np.linalg.norm(A[:, None] - B[None], axis=-1))
        assert np.linalg.norm(pa - pb) <= brute + 1e-12


def test_broadcasting_five_human_by_three_robot_capsules():
    rng = np.random.default_rng(4)
    h0, h1 = rng.normal(size=(2, 5, 1, 3))
    r0, r1 = rng.normal(size=(2, 1, 3, 3))
    hr, rr = np.full((5, 1), 0.1), np.full((1, 3), 0.05)
    d, pa, pb = capsule_distance(h0, h1, hr, r0, r1, rr)
    assert d.shape == (5, 3) and pa.shape == (5, 3, 3) and pb.shape == (5, 3, 3)
    for i in range(5):
        for j in range(3):
            single, _, _ = capsule_distance(h0[i, 0], h1[i, 0], 0.1, r0[0, j], r1[0, j], 0.05)
            assert d[i, j] == pytest.approx(float(single), abs=1e-15)


# --- nearly parallel axes against an exact oracle -----------------------------------------


def exact_segment_distance2(a0, a1, b0, b1) -> Fraction:
    """Squared distance of two segments in exact rational arithmetic (the float inputs are
    exact rationals): the minimum of the convex quadratic over [0, 1]^2 is at the lines'
    stationary point when inside, else on an edge (an end point against the other segment)."""
    A0, A1, B0, B1 = ([Fraction(float(x)) for x in p] for p in (a0, a1, b0, b1))
    d1 = [q - p for p, q in zip(A0, A1)]
    d2 = [q - p for p, q in zip(B0, B1)]
    r = [p - q for p, q in zip(A0, B0)]
    dot = lambda u, v: sum(x * y for x, y in zip(u, v))
    a, e, b, c, f = dot(d1, d1), dot(d2, d2), dot(d1, d2), dot(d1, r), dot(d2, r)
    clamp = lambda x: min(max(x, Fraction(0)), Fraction(1))
    gap2 = lambda s, t: sum((ri + s * u - t * v) ** 2 for ri, u, v in zip(r, d1, d2))
    candidates = []
    for end in (Fraction(0), Fraction(1)):
        candidates.append(gap2(end, clamp((f + end * b) / e) if e else Fraction(0)))
        candidates.append(gap2(clamp((end * b - c) / a) if a else Fraction(0), end))
    denom = a * e - b * b
    if denom > 0:
        s, t = (b * f - c * e) / denom, (a * f - b * c) / denom
        if 0 <= s <= 1 and 0 <= t <= 1:
            candidates.append(gap2(s, t))
    return min(candidates)


def near_parallel_cases(rng, n):
    """Axes whose directions differ by 1e-10 .. 0.1 rad (the kernel's ill-conditioned branch
    starts at sin^2 = 1e-2), side by side, overlapping or apart, either way round, at offsets
    from 0 (nearly collinear) to 1 m."""
    cases = []
    for _ in range(n):
        p = rng.normal(size=3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        normal = np.cross(d, rng.normal(size=3))
        normal /= np.linalg.norm(normal)
        tilt = np.cross(d, rng.normal(size=3))
        tilt /= np.linalg.norm(tilt)
        angle = 10.0 ** rng.uniform(-10, -1)
        d_b = d + angle * tilt
        d_b /= np.linalg.norm(d_b)
        offset = (10.0 ** rng.uniform(-8, 0) if rng.random() < 0.8 else 0.0) * normal
        L1, L2 = rng.uniform(0.1, 1.0, 2)
        b0 = p + offset + rng.uniform(-1.5, 1.5) * d
        b1 = b0 + L2 * d_b
        if rng.random() < 0.5:
            b0, b1 = b1, b0
        cases.append((p, p + L1 * d, rng.uniform(0, 0.2), b0, b1, rng.uniform(0, 0.2)))
    return cases


def test_nearly_parallel_axes_are_exact():
    """Exact to rounding (1e-15 m): before, the clamped 2x2 solve overestimated by up to 1e-6 m."""
    cases = near_parallel_cases(np.random.default_rng(5), 1500)
    a0, a1, ra, b0, b1, rb = (np.array([c[i] for c in cases]) for i in range(6))
    distance, point_a, point_b = capsule_distance(a0, a1, ra, b0, b1, rb)
    exact = np.array([math.sqrt(exact_segment_distance2(*c[:2], *c[3:5])) for c in cases])
    np.testing.assert_allclose(distance + ra + rb, exact, rtol=0, atol=1e-15)
    # The witness points lie on their segments and are as far apart as the distance says.
    np.testing.assert_allclose(np.linalg.norm(point_a - point_b, axis=1), exact, rtol=0, atol=1e-9)
    for p, s0, s1 in ((point_a, a0, a1), (point_b, b0, b1)):
        seg = s1 - s0
        t = np.einsum("ij,ij->i", p - s0, seg) / np.einsum("ij,ij->i", seg, seg)
        assert np.all((t >= -1e-12) & (t <= 1 + 1e-12))
        np.testing.assert_allclose(s0 + t[:, None] * seg, p, rtol=0, atol=1e-12)


def test_exact_oracle_agrees_with_coal_and_random_pairs_are_exact():
    """The oracle itself, checked on generic pairs against coal; the kernel against the oracle."""
    cases = random_cases(np.random.default_rng(6), 300) + degenerate_cases(np.random.default_rng(7))[:300]
    for a0, a1, ra, b0, b1, rb in cases:
        exact = math.sqrt(exact_segment_distance2(a0, a1, b0, b1))
        assert exact - ra - rb == pytest.approx(coal_distance(a0, a1, ra, b0, b1, rb), abs=1e-9)
        distance, _, _ = capsule_distance(a0, a1, ra, b0, b1, rb)
        assert abs(float(distance) + ra + rb - exact) <= 1e-15


# ---- fail closed on bad values (issue 22, item 8) ------------------------------------------
BAD_COORDINATES = (np.nan, np.inf, -np.inf, 1e300, -2e75)
ARGUMENT_NAMES = ("a0", "a1", "ra", "b0", "b1", "rb")


def five_by_three_pairs(rng):
    """5 human x 3 robot capsules, broadcast as the app does: shapes (5, 1, 3) and (1, 3, 3)."""
    return [rng.normal(size=(5, 1, 3)), rng.normal(size=(5, 1, 3)), rng.uniform(0.01, 0.2, (5, 1)),
            rng.normal(size=(1, 3, 3)), rng.normal(size=(1, 3, 3)), rng.uniform(0.01, 0.2, (1, 3))]


@pytest.mark.parametrize("argument", range(6))
@pytest.mark.parametrize("bad", BAD_COORDINATES + (-0.01,))
def test_a_non_finite_negative_or_overflowing_value_is_refused_naming_the_argument(argument, bad):
    rng = np.random.default_rng(argument)
    args = five_by_three_pairs(rng)
    if bad == -0.01 and argument not in (2, 5):
        return  # a negative coordinate is fine; a negative radius is not
    broken = np.array(args[argument], dtype=float)
    broken.reshape(-1)[-1] = bad  # the last element: every row before it is valid
    args[argument] = broken
    with pytest.raises(ValueError, match=rf"capsule_distance: {ARGUMENT_NAMES[argument]}\b"):
        capsule_distance(*args)


def test_the_refusal_names_the_index_in_the_batch():
    rng = np.random.default_rng(1)
    args = five_by_three_pairs(rng)
    args[3] = np.array(args[3])
    args[3][0, 2, 1] = np.nan
    with pytest.raises(ValueError, match=r"b0\[\d, 2\]"):
        capsule_distance(*args)


def test_segment_closest_points_refuses_non_finite_points():
    with pytest.raises(ValueError, match="a1"):
        segment_closest_points(np.zeros(3), np.array([0.0, np.inf, 0.0]), np.ones(3), 2 * np.ones(3))


def test_values_up_to_the_bound_give_finite_results():
    """Random pairs at every scale up to ``MAX_ABS_M``: never NaN, never a refusal."""
    from cobotsafety.geometry.capsule import MAX_ABS_M

    rng = np.random.default_rng(7)
    for exponent in (-300, -5, 0, 5, 50, 74):
        scale = min(10.0 ** exponent, MAX_ABS_M / 4)
        a0, a1, b0, b1 = (np.clip(rng.normal(size=(200, 3)) * scale, -MAX_ABS_M, MAX_ABS_M) for _ in range(4))
        ra, rb = rng.uniform(0, 1, 200) * scale, rng.uniform(0, 1, 200) * scale
        for args in ((a0, a1, ra, b0, b1, rb), (a0, a0, ra, b0, b0, rb), (a0, a1, ra, a0, a1, rb)):
            d, pa, pb = capsule_distance(*args)
            assert np.all(np.isfinite(d)) and np.all(np.isfinite(pa)) and np.all(np.isfinite(pb))
    edge = np.full(3, MAX_ABS_M)
    d, _, _ = capsule_distance(edge, -edge, MAX_ABS_M, -edge, edge, MAX_ABS_M)
    assert np.isfinite(d)


def test_all_pairs_equals_the_broadcast_batch_from_its_first_capsule_on():
    """``all_pairs`` (the arm step's robot-human loop) gives what ``capsule_distance`` gives
    for the same pairs, to the bit (one implementation), from robot capsule ``first`` on;
    none when ``first`` is past the last capsule."""
    from cobotsafety.geometry.capsule import all_pairs

    rng = np.random.default_rng(41)
    for first in (0, 2, 7):
        a0, a1 = rng.normal(size=(2, 7, 3))
        b0, b1 = rng.normal(size=(2, 5, 3))
        ra, rb = rng.uniform(0.02, 0.2, 7), rng.uniform(0.05, 0.3, 5)
        b1[3] = b0[3]  # a point capsule among them
        d, pa, pb = all_pairs(a0, a1, ra, first, b0, b1, rb)
        expected = capsule_distance(a0[first:, None], a1[first:, None], ra[first:, None], b0[None], b1[None], rb[None])
        assert d.shape == (7 - first, 5) and pa.shape == pb.shape == (7 - first, 5, 3)
        for got, want in zip((d, pa, pb), expected, strict=True):
            np.testing.assert_array_equal(got, want)
