"""The recall-first threshold rule of the leg classifier's training (``train_legs.choose_threshold``,
docs/leg_recall.md) on hand-made cross-validation curves."""

from __future__ import annotations

import numpy as np

from cobotsafety.tools.train_legs import choose_threshold, held_out_table

THRESHOLDS = np.array([0.01, 0.02, 0.04, 0.08, 0.12, 0.2, 0.4])
P1, P2, NEG = "positive_1_extracted.bag", "positive_2_extracted.bag", "negative_2.bag/left_scan"


def counts(recalls, false_in_sector, labelled=100, scans=100):
    """One fold's counts per threshold (the detector's and the pipeline's alike)."""
    rows = [{"found": round(labelled * r), "labelled": labelled, "false": round(scans * f) + 7,
             "false_in_sector": round(scans * f), "scans": scans, "torso_errors_m": [0.05]}
            for r, f in zip(recalls, false_in_sector)]
    return {"detector": rows, "pipeline": rows}


def cv_of(p1, p2=None, negative=None, setting="background"):
    """Folds (recalls, false legs per scan in the sector) per threshold."""
    cv = {(P1, setting): counts(*p1), (P2, setting): counts(*(p2 or p1))}
    if negative is not None:
        cv[(NEG, setting)] = counts([0.0] * len(negative), negative, labelled=0)
    return cv


RECALLS = [0.99, 0.97, 0.95, 0.91, 0.88, 0.80, 0.60]


def test_the_lowest_threshold_under_the_cap_off_the_cliff():
    """0.02 is under the cap (0.35) but 0.01 below it (half its odds) is a cliff: not
    admissible. 0.04 holds down to 0.02 (half its odds, inclusive): chosen, the lowest."""
    cv = cv_of((RECALLS, [0.9, 0.3, 0.3, 0.2, 0.1, 0.05, 0.01]))
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background")] == 0.04


def test_recall_never_enters_the_choice_and_the_negative_folds_do_not_count():
    false = [0.9, 0.3, 0.3, 0.2, 0.1, 0.05, 0.01]
    chosen = choose_threshold(cv_of((RECALLS, false)), THRESHOLDS, "background")
    assert choose_threshold(cv_of((RECALLS[::-1], false)), THRESHOLDS, "background") == chosen
    assert choose_threshold(cv_of((RECALLS, false), negative=[9.0] * 7), THRESHOLDS, "background") == chosen


def test_false_legs_are_pooled_over_the_positive_folds():
    """0.30 and 0.38 per scan pooled are 0.34 <= 0.35: 0.04 is admissible (down to 0.02). With
    0.45 instead of 0.38 the pooled 0.375 at 0.02 and 0.04 rules out every threshold whose
    margin reaches 0.04: 0.08 and 0.12 (half their odds: 0.0435, 0.068); 0.2 (down to 0.08)
    is chosen."""
    ok = (RECALLS, [0.9, 0.3, 0.3, 0.3, 0.1, 0.05, 0.01])
    assert THRESHOLDS[choose_threshold(cv_of(ok, (RECALLS, [0.9, 0.38, 0.38, 0.3, 0.1, 0.0, 0.0])),
                                       THRESHOLDS, "background")] == 0.04
    assert THRESHOLDS[choose_threshold(cv_of(ok, (RECALLS, [0.9, 0.45, 0.45, 0.3, 0.1, 0.0, 0.0])),
                                       THRESHOLDS, "background")] == 0.2


def test_a_held_out_bag_never_chooses_its_own_threshold():
    """positive_2's false legs are high up to 0.12: pooled they move the bundled threshold, but
    positive_2's own threshold comes from positive_1 alone, and positive_1's from
    positive_2 alone."""
    p1 = (RECALLS, [0.9, 0.3, 0.3, 0.2, 0.1, 0.05, 0.01])
    p2 = (RECALLS, [0.9, 0.9, 0.9, 0.9, 0.9, 0.05, 0.01])
    cv = cv_of(p1, p2)
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background", held_out=P2)] == 0.04  # from p1
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background", held_out=P1)] == 0.4  # from p2
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background")] == 0.4  # pooled
    table = held_out_table(cv | cv_of(p1, p2, setting="no_background"), THRESHOLDS)
    assert table[f"{P2} (background)"]["threshold"] == 0.04 and table[f"{P2} (background)"]["chosen_without_this_bag"]
    assert table[f"{P1} (background)"]["threshold"] == 0.4


def test_nothing_admissible_gives_the_highest_threshold():
    cv = cv_of((RECALLS, [9.0, 4.0, 1.0, 0.9, 0.8, 0.6, 0.4]))
    assert choose_threshold(cv, THRESHOLDS, "background") == THRESHOLDS.size - 1


def test_the_margin_is_a_factor_of_two_in_the_odds():
    """Near 0.5 half the odds is far less than half the probability: 0.6 (odds 1.5) must hold
    down to 0.4 (odds 0.67 <= 0.75), not to 0.3 (t / 2): with a cliff at 0.3, 0.5 (odds 1,
    down to 0.3, odds 0.43) is not admissible and 0.6 is."""
    thresholds = np.array([0.2, 0.3, 0.4, 0.5, 0.6])
    cv = cv_of(([0.99, 0.95, 0.9, 0.85, 0.8], [0.9, 0.8, 0.2, 0.2, 0.1]), setting="no_background")
    assert thresholds[choose_threshold(cv, thresholds, "no_background")] == 0.6
