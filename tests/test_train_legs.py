"""The threshold rule of the leg classifier's training (``train_legs.choose_threshold``) on
hand-made cross-validation curves."""

from __future__ import annotations

import numpy as np

from cobotsafety.tools.train_legs import choose_threshold

THRESHOLDS = np.array([0.02, 0.04, 0.08, 0.12, 0.2, 0.4])


def cv_of(recalls, false_per_scan, negative=None):
    """Two held-out positive bags (100 labels, 100 scans each) with the same curves; an optional
    negative-bag fold (which the rule must ignore)."""
    counts = [{"found": round(100 * r), "labelled": 100, "false": round(100 * f), "scans": 100}
              for r, f in zip(recalls, false_per_scan)]
    cv = {("positive_1_extracted.bag", "background"): counts, ("positive_2_extracted.bag", "background"): counts}
    if negative is not None:
        cv[("negative_2.bag/left_scan", "background")] = [
            {"found": 0, "labelled": 0, "false": round(100 * f), "scans": 100} for f in negative]
    return cv


def test_the_highest_threshold_with_the_recall_margin_off_the_cliff():
    """0.04 has the best recall under the false-detection cap, but 0.02 just below it is a
    cliff (0.8 per scan): not safe. Of the safe thresholds, 0.08 and 0.12 keep recall >= 0.90;
    the higher wins. The negative bag's fold does not count."""
    cv = cv_of([0.99, 0.97, 0.95, 0.91, 0.88, 0.60], [0.8, 0.3, 0.3, 0.2, 0.1, 0.05], negative=[9.0] * 6)
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background")] == 0.12


def test_without_the_recall_margin_the_best_safe_recall():
    cv = cv_of([0.99, 0.89, 0.88, 0.87, 0.80, 0.60], [0.8, 0.3, 0.3, 0.2, 0.1, 0.05])
    assert THRESHOLDS[choose_threshold(cv, THRESHOLDS, "background")] == 0.08


def test_nothing_safe_gives_the_best_f1():
    """False detections above the cap everywhere: F1 = 2 found / (labelled + found + false)."""
    recalls, false = [0.99, 0.9, 0.8, 0.6, 0.4, 0.1], [9.0, 4.0, 1.0, 0.9, 0.8, 0.4]
    cv = cv_of(recalls, false)
    f1 = [2 * r / (1 + r + f) for r, f in zip(recalls, false)]
    assert choose_threshold(cv, THRESHOLDS, "background") == int(np.argmax(f1))


def test_the_margin_is_a_factor_of_two_in_the_odds():
    """Near 0.5 half the odds is far less than half the probability: 0.6 (odds 1.5) must hold
    down to 0.4 (odds 0.67 <= 0.75), not to 0.3 (t / 2): with a cliff at 0.3, 0.6 is safe,
    and 0.5 (odds 1 -> down to 0.3, odds 0.43) is not."""
    thresholds = np.array([0.2, 0.3, 0.4, 0.5, 0.6])
    counts = [{"found": round(100 * r), "labelled": 100, "false": round(100 * f), "scans": 100}
              for r, f in zip([0.99, 0.95, 0.9, 0.85, 0.8], [0.9, 0.8, 0.2, 0.2, 0.1])]
    cv = {("positive_1_extracted.bag", "no_background"): counts, ("positive_2_extracted.bag", "no_background"): counts}
    assert thresholds[choose_threshold(cv, thresholds, "no_background")] == 0.6
