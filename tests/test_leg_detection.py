"""detect_legs with the learned classifier on synthetic scans: contract, bad inputs, methods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety import LaserScan, detect_legs
from cobotsafety.sensors.leg_clusters import segment
from cobotsafety.sensors.legs import MAX_LEG_WIDTH_M, learned_legs


def render(circles, beams=271, fov_deg=270.0, max_range=8.0, noise=0.0, seed=0, walls=()):
    """Ray-cast circles (x, y, radius) and walls (lines x = a) into a scan."""
    angle_min = -math.radians(fov_deg) / 2
    inc = math.radians(fov_deg) / (beams - 1)
    angles = angle_min + inc * np.arange(beams)
    ranges = np.full(beams, np.inf)
    for cx, cy, r in circles:
        b = np.cos(angles) * cx + np.sin(angles) * cy
        disc = b**2 - (cx**2 + cy**2 - r**2)
        t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
        hit = (disc >= 0) & (t > 0)
        ranges = np.where(hit & (t < ranges), t, ranges)
    for a in walls:
        with np.errstate(divide="ignore"):
            t = a / np.cos(angles)
        ranges = np.where((t > 0) & (t < ranges), t, ranges)
    ranges = np.where(ranges > max_range, np.inf, ranges)
    ranges = ranges + noise * np.random.default_rng(seed).normal(size=beams)
    return LaserScan(angle_min, inc, 0.05, max_range, ranges)


LEGS = np.array([[1.0, 0.13], [1.0, -0.13]])


@pytest.mark.parametrize("beams, fov", [(271, 270.0), (768, 270.0), (512, 180.0), (181, 180.0)])
def test_two_legs_found_at_any_resolution(beams, fov):
    """Both legs, on their axes (eq. 3) within a beam or two. At the recall-first threshold a
    piece of the wall between the legs' shadows may be called a leg too (a phantom: it only
    slows the robot); nothing else is."""
    scan = render([(x, y, 0.06) for x, y in LEGS], beams=beams, fov_deg=fov, noise=0.005, walls=(3.0,))
    legs = detect_legs(scan, max_range_m=6.0)
    distance = np.linalg.norm(legs[:, None] - LEGS[None], axis=-1)
    assert np.all(distance.min(axis=0) < 0.025)
    others = legs[distance.min(axis=1) >= 0.025]
    assert others.shape[0] <= 2 and np.all(np.abs(others[:, 0] - 3.06) < 0.03)  # on the wall x = 3 m


def test_a_wall_alone_is_no_leg():
    for wall in (0.8, 2.0, 4.0):
        assert detect_legs(render([], walls=(wall,), noise=0.003), max_range_m=6.0).shape == (0, 2)


def test_clip_range_applies_to_the_detections():
    scan = render([(2.0, 0.13, 0.06), (2.0, -0.13, 0.06)], beams=811, noise=0.003)
    assert detect_legs(scan).shape == (0, 2)  # default 1.4 m
    assert detect_legs(scan, max_range_m=3.0).shape == (2, 2)


def test_background_removes_a_static_post():
    post = (0.7, -0.5, 0.06)
    empty = render([post])
    scene = render([post, (1.0, 0.4, 0.06)])
    legs = detect_legs(scene, 3.0, background=empty.ranges)
    assert legs.shape == (1, 2)
    assert np.linalg.norm(legs[0] - [1.0, 0.4]) < 0.015
    with pytest.raises(ValueError, match="background"):
        detect_legs(scene, background=np.ones(3))


def test_methods_dispatch():
    scan = render([(x, y, 0.06) for x, y in LEGS])
    np.testing.assert_array_equal(detect_legs(scan, method="learned"), learned_legs(scan))
    paper = detect_legs(scan, method="paper")
    assert paper.shape == (2, 2)  # the paper's rule: centres one leg radius behind the minima
    np.testing.assert_allclose(np.sort(paper[:, 1]), np.sort(LEGS[:, 1]), atol=0.03)
    with pytest.raises(ValueError, match="method"):
        detect_legs(scan, method="magic")


def test_no_return_readings_are_never_legs():
    ranges = np.full(271, np.inf)
    for start, value in ((100, 0.0), (120, np.nan), (140, 0.01), (160, 20.0), (180, -np.inf)):
        ranges[start:start + 8] = value
    scan = LaserScan(-2.35, 0.0174, 0.05, 8.0, ranges)
    assert segment(scan).count == 0
    assert detect_legs(scan, max_range_m=30.0).shape == (0, 2)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from([0.0, np.nan, np.inf, -np.inf, 1e-3, 50.0]), min_size=2, max_size=400),
       st.lists(st.tuples(st.integers(0, 399), st.floats(0.3, 5.0)), max_size=5))
def test_legs_only_come_from_usable_returns(bad, real):
    """Scans of no-returns with a few real readings: every leg lies at a usable return's cluster."""
    ranges = np.array(bad, dtype=float)
    for i, r in real:
        if i < ranges.size:
            ranges[i] = r
    scan = LaserScan(-1.5, 0.01, 0.05, 10.0, ranges)
    legs = detect_legs(scan, max_range_m=10.0)
    assert legs.shape[1] == 2 and np.all(np.isfinite(legs))
    # A cluster needs 3 usable returns; fewer than 3 real readings can never make a leg.
    if np.count_nonzero(scan.valid) < 3:
        assert legs.shape == (0, 2)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.1, 10.0), min_size=3, max_size=60), st.integers(1, 7), st.integers(1, 4))
def test_nearest_averaged_return_kernel_equals_reference(ranges, smoothing_beams, pieces):
    from cobotsafety.sensors.legs import _nearest_averaged_returns, nearest_averaged_returns_reference

    ranges = np.array(ranges)
    cuts = np.linspace(0, ranges.size, pieces + 1).astype(np.int64)
    starts, stops = cuts[:-1], cuts[1:]
    ok = stops > starts
    starts, stops = starts[ok], stops[ok]
    index, value = _nearest_averaged_returns(ranges, starts, stops, smoothing_beams)
    index_ref, value_ref = nearest_averaged_returns_reference(ranges, starts, stops, smoothing_beams)
    np.testing.assert_allclose(value, value_ref, rtol=1e-12, atol=1e-12)
    # Ties between equal windows may pick either index; the averaged value is what matters.
    assert np.all((index >= starts) & (index < stops))


def test_clusters_wider_than_two_legs_are_never_legs():
    """Even a forest that calls everything a leg (threshold below 0) keeps walls out: a cluster
    wider than MAX_LEG_WIDTH_M end to end is not a leg; the two legs in front still are."""
    scan = render([(x, y, 0.06) for x, y in LEGS], beams=811, walls=(2.0,))
    everything = learned_legs(scan, 6.0, threshold_probability=-1.0)
    clusters = segment(scan)
    last = clusters.stops - 1
    width = np.hypot(clusters.x_m[last] - clusters.x_m[clusters.starts], clusters.y_m[last] - clusters.y_m[clusters.starts])
    assert np.any(width > MAX_LEG_WIDTH_M) and everything.shape[0] == np.sum(width <= MAX_LEG_WIDTH_M)
    found = np.linalg.norm(everything[:, None] - LEGS[None], axis=-1).min(axis=0)
    assert np.all(found < 0.03)
    wide = learned_legs(scan, 6.0, threshold_probability=-1.0, max_width_m=np.inf)
    assert wide.shape[0] == clusters.count


def test_background_share_counts_each_cluster_own_returns_only():
    """A cluster in front of the background counts, one on it does not, whatever lies between
    or after them (dropped 2-return clusters, the rest of the scan)."""
    inc = math.radians(0.5)
    # On the background: the 4 m, 3 m and 5 m clusters; in front: the 1 m cluster and the
    # 2-return piece after the 3 m cluster (dropped: too few returns).
    ranges = np.r_[np.full(30, 4.0), np.full(8, 1.0), np.full(3, 3.0), [2.5, 2.5], np.full(30, 5.0)]
    background = np.r_[np.full(30, 4.0), np.full(8, 4.0), np.full(3, 3.0), [4.0, 4.0], np.full(30, 5.0)]
    scan = LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)
    legs = learned_legs(scan, 6.0, background, threshold_probability=-1.0)
    assert legs.shape == (1, 2)
    assert abs(np.hypot(*legs[0]) - (1.0 + 0.06)) < 1e-9  # the 1 m cluster, eq. 3


def test_a_cluster_counts_with_a_cluster_worth_of_returns_in_front_of_the_background():
    """MIN_CLUSTER_POINTS returns in front of the background are enough (a leg half over a spot
    where someone stood still); fewer, and not more than half, are not (edge flicker)."""
    inc = math.radians(0.5)
    wall = np.full(30, 4.0)
    for in_front, expected in ((3, 1), (2, 0)):
        # One 10-return cluster at ~1 m; the empty scene had the 4 m wall behind its first
        # in_front beams and the rest of it (someone standing still) as it is now.
        ranges = np.r_[wall, np.full(in_front, 1.0), np.full(10 - in_front, 1.05), wall]
        background = np.r_[wall, np.full(in_front, 4.0), np.full(10 - in_front, 1.05), wall]
        scan = LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)
        assert segment(scan).count == 3
        legs = learned_legs(scan, 6.0, background, threshold_probability=-1.0)
        assert legs.shape == (expected, 2)


def test_a_small_cluster_counts_when_most_of_its_returns_are_in_front_of_the_background():
    """Fewer than MIN_CLUSTER_POINTS returns in front still count when they are most of the
    cluster (a small, far leg); a minority does not."""
    inc = math.radians(0.5)
    wall = np.full(30, 4.0)
    ranges = np.r_[wall, [1.0, 1.0, 1.02], wall]
    for background_part, expected in (([4.0, 4.0, 1.02], 1), ([4.0, 1.0, 1.02], 0)):
        background = np.r_[wall, background_part, wall]
        scan = LaserScan(-inc * (ranges.size - 1) / 2, inc, 0.02, 20.0, ranges)
        assert segment(scan).count == 3
        legs = learned_legs(scan, 6.0, background, threshold_probability=-1.0)
        assert legs.shape == (expected, 2), background_part


@pytest.mark.parametrize("no_return", [np.inf, 0.0, -1.0])
def test_a_background_beam_without_a_return_hides_nothing(no_return):
    """A background beam that never returned (open space: +inf; 0 or less, as drivers write "no
    return") removes nothing in front of it: the legs are those found without a background."""
    scan = render([(x, y, 0.06) for x, y in LEGS], walls=(3.0,), noise=0.003)
    near = lambda legs: np.sort(legs[np.hypot(legs[:, 0], legs[:, 1]) < 2.0], axis=0)  # noqa: E731 (the wall's own, without a background)
    without = near(learned_legs(scan, 6.0))
    background = np.where(np.isfinite(scan.ranges) & (scan.ranges > 2.5), scan.ranges, no_return)  # the wall
    assert without.shape[0] == 2
    np.testing.assert_allclose(near(learned_legs(scan, 6.0, background)), without)


# --- Fail closed: input that would make the detector blind is refused, never "nobody". ---

TWO_LEGS = render([(x, y, 0.06) for x, y in LEGS], walls=(3.0,), noise=0.003)


@pytest.mark.parametrize("method", ["learned", "paper"])
@pytest.mark.parametrize("max_range_m", [np.nan, -1.0, 0.0, np.inf, -np.inf, "far"])
def test_a_blind_range_is_refused(method, max_range_m):
    with pytest.raises(ValueError, match="max_range_m"):
        detect_legs(TWO_LEGS, max_range_m, method=method)


@pytest.mark.parametrize("method", ["learned", "paper"])
@pytest.mark.parametrize("bad", [np.nan, -np.inf])
def test_a_background_with_nan_or_minus_inf_is_refused(method, bad):
    background = np.full(TWO_LEGS.ranges.size, 3.0)
    background[17] = bad
    with pytest.raises(ValueError, match="background.*beam 17"):
        detect_legs(TWO_LEGS, 6.0, background, method=method)
    background[17] = np.inf  # open space: allowed, and the legs in front are still found
    assert detect_legs(TWO_LEGS, 6.0, background, method=method).shape == (2, 2)


@pytest.mark.parametrize("option, value", [
    ("threshold_probability", np.nan), ("threshold_probability", 1.0), ("threshold_probability", np.inf),
    ("background_margin_m", np.nan), ("background_margin_m", -0.1), ("leg_radius_m", np.nan),
    ("leg_radius_m", np.inf), ("smoothing_beams", 0), ("smoothing_beams", 1.5), ("smoothing_beams", np.nan),
    ("max_width_m", np.nan), ("max_width_m", 0.0),
])
def test_learned_options_that_hide_every_leg_are_refused(option, value):
    with pytest.raises(ValueError, match=option):
        detect_legs(TWO_LEGS, 6.0, **{option: value})


@pytest.mark.parametrize("option, value", [
    ("jump_m", np.nan), ("jump_m", 0.0), ("min_width_m", np.nan), ("max_width_m", np.nan), ("max_width_m", 0.01),
    ("leg_radius_m", np.nan), ("background_margin_m", np.nan), ("smoothing_beams", 0),
])
def test_paper_options_that_hide_every_leg_are_refused(option, value):
    with pytest.raises(ValueError, match=option):
        detect_legs(TWO_LEGS, 6.0, method="paper", **{option: value})


@pytest.mark.parametrize("method", ["learned", "paper"])
def test_a_scan_of_more_than_one_revolution_is_refused(method):
    """One scan is one sweep: a crafted message with 10^5 beams of 0.35 deg (98 turns)."""
    scan = LaserScan(-math.pi, math.radians(0.352), 0.05, 8.0, np.resize(TWO_LEGS.ranges, 100_000))
    with pytest.raises(ValueError, match="revolution"):
        detect_legs(scan, 6.0, method=method)
    full = LaserScan(-math.pi, 2 * math.pi / 720, 0.05, 8.0, np.full(721, np.inf))  # -pi..pi, both ends
    assert detect_legs(full, 6.0, method=method).shape == (0, 2)


# --- Linear time: a fine scan is decimated to the trained beam spacing before clustering. ---

@settings(max_examples=200, deadline=None)
@given(st.floats(1e-7, 0.05), st.integers(2, 3_000_000))
def test_at_most_two_thousand_beams_reach_the_clustering(increment_rad, beams):
    """Whatever the beam spacing, one revolution leaves fewer than 2 * 2 pi / FINEST + 2 beams
    (the quadratic context then costs a bounded amount) and never a spacing finer than half
    the trained one, nor coarser than the trained one unless the scan was already."""
    from cobotsafety.sensors.legs import FINEST_INCREMENT_RAD, at_trained_resolution

    beams = min(beams, int(2 * math.pi / increment_rad) + 1)
    if beams < 2:
        return
    ranges = np.zeros(beams)  # contents do not matter here
    coarse, background = at_trained_resolution(LaserScan(-1.0, increment_rad, 0.05, 8.0, ranges), ranges)
    assert coarse.ranges.size <= 2 * 2 * math.pi / FINEST_INCREMENT_RAD + 2
    assert background.shape == coarse.ranges.shape and coarse.ranges.size >= 2
    if beams > 2 * FINEST_INCREMENT_RAD / increment_rad:  # else two beams are all there is to keep
        assert coarse.angle_increment > FINEST_INCREMENT_RAD / 2 - 1e-15
    if increment_rad <= FINEST_INCREMENT_RAD:
        assert coarse.angle_increment <= FINEST_INCREMENT_RAD * (1 + 1e-9)
    else:
        assert coarse.angle_increment == increment_rad


def test_a_million_beams_give_the_legs_of_the_trained_resolution(monkeypatch):
    """The same two legs and wall ray-cast at the bags' 768 beams over 270 deg and at 10^6:
    the same legs (within a beam's width), and the clustering sees ~768 beams, not 10^6."""
    import cobotsafety.sensors.legs as legs_module

    seen = []
    segment_of = legs_module.segment
    monkeypatch.setattr(legs_module, "segment", lambda scan: seen.append(scan.ranges.size) or segment_of(scan))
    native = render([(x, y, 0.06) for x, y in LEGS], beams=768, walls=(3.0,))
    fine = render([(x, y, 0.06) for x, y in LEGS], beams=767 * 1302 + 1, walls=(3.0,))
    legs_native, legs_fine = detect_legs(native, 6.0), detect_legs(fine, 6.0)
    assert seen[0] == 768 and abs(seen[1] - 768) <= 2  # 1300 fine beams per coarse one
    assert legs_native.shape == legs_fine.shape == (2, 2)
    np.testing.assert_allclose(np.sort(legs_fine, axis=0), np.sort(legs_native, axis=0), atol=0.01)
