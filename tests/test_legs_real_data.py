"""The leg detectors on the real, hand-labelled scans of ../shared/data/leg_tracker.

The bundled forest was trained on these bags, so its own figures on them are optimistic; the
thresholds here are checked the way the training report's cross-validation checks them: a
forest trained (same recipe) without the bag it is scored on.
"""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.tools import train_legs
from cobotsafety.tools.evaluate_legs import evaluate_all
from cobotsafety.sensors.leg_classifier import LegForest, bundled_forest
from cobotsafety.sensors.legs import detect_legs, estimate_background, learned_legs


@pytest.fixture(scope="module")
def bags(shared_data):
    return train_legs.load_bags(shared_data / "leg_tracker")


_HELD_OUT: dict[tuple[str, ...], LegForest] = {}


def held_out_forest(bags, held_out: list[str]) -> LegForest:
    """The training recipe without ``held_out``, the bundled thresholds (trained once per session)."""
    key = tuple(held_out)
    if key not in _HELD_OUT:
        names = [n for n in bags if n not in held_out]
        bundled = bundled_forest()
        _HELD_OUT[key] = LegForest.from_sklearn(train_legs.fit(*train_legs.training_set(bags, names)),
                                                bundled.threshold_probability,
                                                bundled.threshold_probability_no_background)
    return _HELD_OUT[key]


@pytest.mark.parametrize("held, labelled", [("positive_1_extracted.bag", 324), ("positive_2_extracted.bag", 116)])
def test_unseen_labelled_bag_with_a_background(bags, held, labelled):
    """Trained without the bag (the other positive bag, negative_2, the rendered examples),
    scored on it (6 m, per-beam background): the aim's recall. False detections are counted
    where the labels are complete: leg_tracker labelled every cluster within +-15 deg and 5 m
    of the scanner and nothing elsewhere (positive_2 has unlabelled people beside the sector)."""
    forest = held_out_forest(bags, [held])
    scans = bags[held]
    background = estimate_background([s for s, _ in scans])
    sector = []

    def detect(scan):
        legs = learned_legs(scan, 6.0, background, forest=forest)
        sector.append(legs[(np.abs(np.arctan2(legs[:, 1], legs[:, 0])) <= np.radians(15.0))
                           & (np.hypot(legs[:, 0], legs[:, 1]) <= 5.0)])
        return legs

    score = train_legs.score_bag(scans, detect)
    assert score["labelled"] == labelled
    assert score["found"] / score["labelled"] >= 0.85
    false_in_sector = 0
    for (_, labels), legs in zip(scans, sector):
        if legs.size:
            far = np.linalg.norm(legs[:, None] - labels[None], axis=-1).min(axis=1) > train_legs.HIT_RADIUS_M
            false_in_sector += int(far.sum())
    assert false_in_sector / score["scans"] <= 0.1
    if held == "positive_1_extracted.bag":  # few people outside the sector there
        assert score["false"] / score["scans"] <= 0.5


@pytest.mark.parametrize("held, min_recall", [("positive_1_extracted.bag", 0.55), ("positive_2_extracted.bag", 0.85)])
def test_unseen_labelled_bag_without_a_background(bags, held, min_recall):
    """No background (a moving scanner has none), 6 m, the bundled no-background threshold, a
    model trained without the bag: false detections <= 0.5 per scan counted everywhere (the
    room's chair and table legs are in every scan), torso median <= 0.10 m. Recall: the aim
    (0.85) where the model was trained on positive_1's 324 labelled legs; holding positive_1
    out leaves positive_2's 116, and it finds ~62 % (its misses are mostly legs of walking
    pairs, which positive_2 hardly shows)."""
    forest = held_out_forest(bags, [held])
    score = train_legs.score_bag(bags[held], lambda s: learned_legs(s, 6.0, None, forest=forest))
    assert score["found"] / score["labelled"] >= min_recall
    assert score["false"] / score["scans"] <= 0.5
    assert np.median(score["torso_errors_m"]) <= 0.10


def test_nobody_in_view_gives_fewer_detections_than_the_paper_rule(bags):
    """Trained without the right-hand scanner of the negative bag, scored on it (no background:
    the scanners move). Chair and table legs remain leg-like: ~2 per scan at 6 m (the paper's
    rule: ~10; shape alone: ~3), the weak point of a single-scan detector without a background."""
    held = "negative_2.bag/right_scan"
    forest = held_out_forest(bags, [held])
    learned = train_legs.score_bag(bags[held], lambda s: learned_legs(s, 6.0, None, forest=forest))
    paper = train_legs.score_bag(bags[held], lambda s: detect_legs(s, 6.0, None, method="paper"))
    assert learned["labelled"] == 0
    assert learned["false"] / learned["scans"] <= 4.5
    assert learned["false"] <= 0.5 * paper["false"]


def test_evaluate_legs_reports_every_method_and_setting(shared_data):
    data = shared_data / "leg_tracker"
    result = evaluate_all([data / "positive_2_extracted.bag"], settings={"6m_background": (6.0, True)})
    rows = result["6m_background"]
    assert set(rows) == {"paper", "learned", "learned+tracker"}
    for method, bags_ in rows.items():
        m = bags_["positive_2_extracted.bag"]
        assert m["scans"] == 83 and m["labelled"] == 116
        assert 0.0 <= m["recall"] <= 1.0 and m["false_per_scan"] >= 0.0
    # The bundled forest saw this bag: an upper bound, but it must beat the paper's rule.
    assert rows["learned"]["positive_2_extracted.bag"]["recall"] > rows["paper"]["positive_2_extracted.bag"]["recall"]
    assert rows["learned"]["positive_2_extracted.bag"]["torso_error_median_m"] <= 0.10
