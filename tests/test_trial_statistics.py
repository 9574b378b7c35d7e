"""The trial statistics pinned to independent values: exact p-values and U/W by enumeration and
by paper 1's own numbers, tails, Holm, BCa against scipy's bootstrap, data where pairing matters,
the interaction's direction on log time (rank test and mixed model), the order check's power."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.stats import bootstrap, rankdata

from cobotsafety.trial.comparisons import compare_all
from cobotsafety.trial.rank_tests import mann_whitney_test, signed_rank_test
from cobotsafety.trial.statistics import (
    ABS_INTERACTION,
    BOOTSTRAP_RESAMPLES,
    BOOTSTRAP_SEED,
    LOG_INTERACTION,
    SLIDING,
    STOP,
    by_participant,
    describe,
    holm,
    mann_whitney,
    order_effect,
    signed_rank,
)

N10 = math.comb(20, 10)  # 184756 ways to split 20 ranks into two groups of 10


def enumerate_u(sliding, stop):
    """Every split of the pooled values (midranks): the U of the first group, by brute force."""
    pooled = np.concatenate([sliding, stop])
    ranks = rankdata(pooled)
    n1 = len(sliding)
    us = [ranks[list(group)].sum() - n1 * (n1 + 1) / 2 for group in itertools.combinations(range(len(pooled)), n1)]
    observed = ranks[:n1].sum() - n1 * (n1 + 1) / 2
    return np.array(us), observed


def enumerate_w(d):
    """Every sign flip of the non-zero differences: the rank sum of the positive ones."""
    d = np.asarray(d, float)
    d = d[d != 0]
    ranks = rankdata(np.abs(d))
    ws = [sum(r for r, s in zip(ranks, signs) if s > 0) for signs in itertools.product((1, -1), repeat=len(d))]
    return np.array(ws), float(ranks[d > 0].sum())


def normal_p_less(u, n1, n2):
    """Paper 1's kind of p: the normal approximation with continuity correction, no ties."""
    mu, sigma = n1 * n2 / 2, math.sqrt(n1 * n2 * (n1 + n2 + 1) / 12)
    z = (u + 0.5 - mu) / sigma
    return 0.5 * math.erfc(-z / math.sqrt(2))


def test_papers_p_00009_is_u_0_by_the_normal_approximation_and_the_exact_p_is_smaller():
    sliding, stop = np.arange(10.0), np.arange(10.0) + 20.0
    res = mann_whitney_test(sliding, stop, "less")
    assert res.statistic == 0.0 and res.method == "exact"
    assert res.p == pytest.approx(1 / N10, rel=1e-9)  # the only split with U = 0
    assert round(normal_p_less(0, 10, 10), 5) == 0.00009  # paper 1, IV.B
    assert normal_p_less(0, 10, 10) / res.p > 15  # the approximation overstates p ~17x here


def test_papers_p_00064_is_about_u_7_and_its_exact_p_comes_from_counting_partitions():
    stop = np.arange(10.0, 20.0)
    sliding = np.append(np.arange(9.0), 16.5)  # its largest value beats 7 stop values
    res = mann_whitney_test(sliding, stop, "less")
    assert res.statistic == 7.0 and res.method == "exact"
    partitions = [1, 1, 2, 3, 5, 7, 11, 15]  # p(0..7): splits with U = u for u < 10
    assert res.p == pytest.approx(sum(partitions) / N10, rel=1e-9)
    assert normal_p_less(7, 10, 10) == pytest.approx(0.00064, abs=2e-5)  # paper 1, IV.A
    greater = mann_whitney_test(sliding, stop, "greater")
    assert greater.statistic == 7.0
    assert greater.p == pytest.approx(1 - sum(partitions[:7]) / N10, rel=1e-9)
    two = mann_whitney_test(sliding, stop, "two-sided")
    assert two.p == pytest.approx(2 * res.p, rel=1e-9)


def test_ties_get_the_exact_conditional_p_by_enumeration_not_the_normal_approximation():
    # The case: scores with heavy ties, one participant lost 3 points.
    sliding = np.zeros(5)
    stop = np.array([0.0, 0.0, 0.0, 0.0, -3.0])
    us, observed = enumerate_u(sliding, stop)
    res = mann_whitney_test(sliding, stop, "greater")  # sliding higher = fewer points lost
    assert res.method == "exact" and res.statistic == observed
    assert res.p == pytest.approx(np.mean(us >= observed - 1e-9))
    assert res.p == pytest.approx(0.5)
    rng = np.random.default_rng(11)
    for _ in range(5):  # random tied data: same as brute force
        a, b = rng.integers(0, 3, 6).astype(float), rng.integers(0, 4, 5).astype(float)
        if np.ptp(np.concatenate([a, b])) == 0:
            continue
        us, observed = enumerate_u(a, b)
        for tail, ref in (("less", np.mean(us <= observed + 1e-9)), ("greater", np.mean(us >= observed - 1e-9))):
            assert mann_whitney_test(a, b, tail).p == pytest.approx(ref)


def test_exact_p_with_ties_equals_scipys_full_permutation_test():
    from scipy.stats import permutation_test

    rng = np.random.default_rng(12)
    for _ in range(3):
        a, b = rng.integers(-4, 1, 10).astype(float), rng.integers(-6, 1, 10).astype(float)
        ranks = rankdata(np.concatenate([a, b]))
        ref = permutation_test((ranks[:10], ranks[10:]), lambda x, y, axis=-1: np.sum(x, axis=axis),
                               permutation_type="independent", alternative="greater", n_resamples=np.inf,
                               vectorized=True).pvalue
        assert mann_whitney_test(a, b, "greater").p == pytest.approx(ref, rel=1e-9)
        d = np.round(rng.normal(0.5, 2.0, 12))
        d = d[d != 0]
        signed = rankdata(np.abs(d)) * np.sign(d)
        ref = permutation_test((signed,), lambda s, axis=-1: np.sum(np.where(s > 0, s, 0), axis=axis),
                               permutation_type="samples", alternative="less", n_resamples=np.inf,
                               vectorized=True).pvalue
        assert signed_rank_test(d, np.zeros_like(d), "less").p == pytest.approx(ref, rel=1e-9)


def test_signed_rank_w_and_exact_p_by_enumeration_with_and_without_ties():
    rng = np.random.default_rng(5)
    for ties in (False, True):
        for _ in range(4):
            sliding = rng.normal(30, 5, 9)
            stop = sliding + rng.normal(2, 3, 9)
            if ties:
                stop = np.round(stop)
                sliding = np.round(sliding)
            d = sliding - stop
            if not np.any(d):
                continue
            ws, observed = enumerate_w(d)
            res = signed_rank_test(sliding, stop, "less")
            assert res.method == "exact" and res.statistic == pytest.approx(observed)
            assert res.p == pytest.approx(np.mean(ws <= observed + 1e-9))
            assert signed_rank_test(sliding, stop, "greater").p == pytest.approx(np.mean(ws >= observed - 1e-9))


def test_tails_follow_the_sliding_minus_stop_direction():
    rng = np.random.default_rng(1)
    stop = rng.normal(40, 6, 10)
    sliding = stop - 8 + rng.normal(0, 1, 10)  # sliding faster
    fast = mann_whitney("t", sliding, stop, "less", with_ci=False)
    assert fast.tail == "less" and fast.p < 0.01 and fast.effect_size > 0.5
    wrong_way = mann_whitney("t", sliding, stop, "greater", with_ci=False)
    assert wrong_way.p > 0.95  # a two-sided or flipped test would not give this
    paired = signed_rank("t", sliding, stop, "less", with_ci=False)
    assert paired.tail == "less" and paired.p == pytest.approx(1 / 1024) and paired.statistic == 0.0
    assert signed_rank("t", sliding, stop, "greater", with_ci=False).p == pytest.approx(1.0)
    # Scores: higher is better, tail "greater".
    scores = compare_all(_records(sliding, stop, score_sliding=-np.ones(10), score_stop=-5 * np.ones(10)),
                         with_ci=False, order_power=False)
    row = next(r for r in scores if r.comparison == "divided attention: error score [points]"
               and r.test.startswith("wilcoxon"))
    assert row.tail == "greater" and row.p < 0.01


def test_the_paired_effect_size_is_positive_when_sliding_is_favoured_in_either_tail():
    """The matched-pairs rank-biserial effect: +1 when every pair favours sliding (lower times with
    ``less``, higher scores with ``greater``), -1 when every pair favours stop; and with fewer than
    five non-zero pairs the result says the test cannot reach 0.05."""
    stop = np.linspace(30.0, 48.0, 10)
    faster = stop - np.linspace(1.0, 5.0, 10)
    assert signed_rank("t", faster, stop, "less", with_ci=False).effect_size == pytest.approx(1.0)
    assert signed_rank("t", stop, faster, "less", with_ci=False).effect_size == pytest.approx(-1.0)
    assert signed_rank("s", stop, faster, "greater", with_ci=False).effect_size == pytest.approx(1.0)
    few = signed_rank("t", faster[:4], stop[:4], "less", with_ci=False)
    assert few.p == pytest.approx(0.5 ** 4) and "cannot reach 0.05" in few.reason
    assert signed_rank("t", faster[:5], stop[:5], "less", with_ci=False).reason == ""


def test_pairing_matters_where_people_differ_more_than_the_conditions():
    """Big differences between people, the same 2 s gain for each: the paired test sees it, the
    independent-groups test cannot."""
    people = np.linspace(20.0, 80.0, 10)
    stop, sliding = people + 2.0, people
    assert signed_rank("t", sliding, stop, with_ci=False).p == pytest.approx(1 / 1024)
    assert mann_whitney("t", sliding, stop, with_ci=False).p > 0.3


def test_bca_interval_of_the_mean_difference_equals_scipys_bootstrap():
    rng = np.random.default_rng(8)
    stop = rng.normal(40, 6, 10)
    sliding = stop - rng.gamma(2.0, 3.0, 10)  # skewed gains: BCa and percentile differ
    got = signed_rank("t", sliding, stop).ci95
    ref = bootstrap((sliding - stop,), np.mean, confidence_level=0.95, n_resamples=BOOTSTRAP_RESAMPLES, method="BCa",
                    random_state=np.random.default_rng(BOOTSTRAP_SEED)).confidence_interval
    assert got == pytest.approx((ref.low, ref.high), abs=1e-10)
    percentile = bootstrap((sliding - stop,), np.mean, n_resamples=BOOTSTRAP_RESAMPLES, method="percentile",
                           random_state=np.random.default_rng(BOOTSTRAP_SEED)).confidence_interval
    median = bootstrap((sliding - stop,), np.median, n_resamples=BOOTSTRAP_RESAMPLES, method="BCa",
                       random_state=np.random.default_rng(BOOTSTRAP_SEED)).confidence_interval
    assert abs(percentile.low - ref.low) > 1e-3 and abs(median.low - ref.low) > 1e-3  # the test can tell
    groups = mann_whitney("t", sliding, stop).ci95
    ref2 = bootstrap((sliding, stop), lambda a, b, axis=-1: np.mean(a, axis=axis) - np.mean(b, axis=axis),
                     n_resamples=BOOTSTRAP_RESAMPLES, method="BCa",
                     random_state=np.random.default_rng(BOOTSTRAP_SEED)).confidence_interval
    assert groups == pytest.approx((ref2.low, ref2.high), abs=1e-10)


def test_holm_against_the_step_down_rule_by_hand():
    from cobotsafety.trial.statistics import Result

    ps = [0.01, 0.04, 0.03, 0.2]
    rows = [Result(f"c{i}", "mann-whitney one-tailed", 10, 0, 0, p, 0, None, role="secondary") for i, p in enumerate(ps)]
    rows.append(Result("other", "wilcoxon signed-rank one-tailed", 10, 0, 0, 0.02, 0, None, role="secondary"))
    rows.append(Result("check", "mann-whitney two-sided", 10, 0, 0, 0.02, 0, None, role="check"))
    out = holm(rows)
    order = np.argsort(ps)
    expected, running = [0.0] * 4, 0.0
    for k, i in enumerate(order):  # step-down: (m - k) p, made monotone, capped at 1
        running = max(running, min(1.0, (4 - k) * ps[i]))
        expected[i] = running
    assert [r.p_holm for r in out[:4]] == pytest.approx(expected)
    assert out[4].p_holm == pytest.approx(0.02)  # its own family of one
    assert out[5].p_holm is None  # checks are not corrected


def _records(sliding_full, stop_full, sliding_div=None, stop_div=None, score_sliding=None, score_stop=None,
             sliding_first=None):
    """Four trials per participant; ``sliding_first[i]``: that participant's condition order; the
    attention order alternates in pairs of participants (counterbalanced, as ``plan`` deals it)."""
    n = len(sliding_full)
    sliding_div = sliding_full * 1.3 if sliding_div is None else sliding_div
    stop_div = stop_full * 1.3 if stop_div is None else stop_div
    score_sliding = np.zeros(n) if score_sliding is None else score_sliding
    score_stop = np.zeros(n) if score_stop is None else score_stop
    sliding_first = [i % 2 == 0 for i in range(n)] if sliding_first is None else sliding_first
    records = []
    for i in range(n):
        first = (SLIDING, STOP) if sliding_first[i] else (STOP, SLIDING)
        full_first = (i // 2) % 2 == 0
        for attention, values, offset in (("full", (sliding_full, stop_full), 1 if full_first else 3),
                                          ("divided", (sliding_div, stop_div), 3 if full_first else 1)):
            for condition in (SLIDING, STOP):
                points = (score_sliding if condition == SLIDING else score_stop)[i] if attention == "divided" else 0
                errors = [{"kind": "wrong", "t_s": 1.0 + 2 * k, "points": -1} for k in range(int(-points))]
                records.append({"participant": f"P{i:02d}", "condition": condition, "attention": attention,
                                "order": offset + first.index(condition), "completion_time_s":
                                float(values[0 if condition == SLIDING else 1][i]), "errors": errors})
    return records


def test_the_interaction_on_log_time_has_the_papers_direction_and_the_mixed_model_agrees():
    rng = np.random.default_rng(21)
    people = rng.uniform(0.7, 1.4, 12)
    full_sliding = 30 * people * rng.lognormal(0, 0.03, 12)
    full_stop = 38 * people * rng.lognormal(0, 0.03, 12)
    div_sliding = full_sliding * 1.30 * rng.lognormal(0, 0.03, 12)  # divided slows sliding by 30 %
    div_stop = full_stop * 1.60 * rng.lognormal(0, 0.03, 12)  # and stop by 60 %: the paper's direction
    results = compare_all(_records(full_sliding, full_stop, div_sliding, div_stop), with_ci=False, order_power=False)
    log_w = next(r for r in results if r.comparison == LOG_INTERACTION and r.test.startswith("wilcoxon"))
    assert log_w.sliding_mean == pytest.approx(np.mean(np.log(div_sliding / full_sliding)))
    assert log_w.sliding_mean < log_w.stop_mean and log_w.tail == "less" and log_w.p < 0.001
    absolute = next(r for r in results if r.comparison == ABS_INTERACTION and r.test.startswith("wilcoxon"))
    assert absolute.sliding_mean == pytest.approx(np.mean(div_sliding - full_sliding))  # divided - full, not the reverse
    assert absolute.sliding_mean > 0 and absolute.p < 0.05
    mixed = next(r for r in results if r.comparison.startswith("attention interaction (mixed model)"))
    expected = np.log(1.30) - np.log(1.60)  # sliding x divided on log time
    assert mixed.effect_size == pytest.approx(expected, abs=0.05) and mixed.p < 0.001
    assert mixed.ci95[0] < expected < mixed.ci95[1] and mixed.p_method == "asymptotic"
    # The reverse: divided slows sliding more. Then nothing is significant in the paper's direction.
    reverse = compare_all(_records(full_sliding, full_stop, full_sliding * 1.6, full_stop * 1.3), with_ci=False,
                          order_power=False)
    assert next(r for r in reverse if r.comparison == LOG_INTERACTION and r.test.startswith("wilcoxon")).p > 0.99
    assert next(r for r in reverse if r.comparison.startswith("attention interaction (mixed")).p > 0.99
    # Same proportional slowdown (no interaction) but stop slower: the absolute comparison calls it
    # an interaction, the log one does not (the point 3).
    scale = compare_all(_records(full_sliding, full_stop, full_sliding * 1.5, full_stop * 1.5), with_ci=False,
                        order_power=False)
    assert next(r for r in scale if r.comparison == ABS_INTERACTION and r.test.startswith("wilcoxon")).p < 0.01
    assert next(r for r in scale if r.comparison == LOG_INTERACTION and r.test.startswith("wilcoxon")).p > 0.05


def test_order_rows_carry_their_groups_and_the_power_of_the_check():
    rng = np.random.default_rng(3)
    n = 10
    stop = rng.normal(40, 4, n)
    sliding = stop - 8 + rng.normal(0, 5, n)
    first = [i < 5 for i in range(n)]
    row = order_effect(by_participant(_records(sliding, stop, sliding_first=first)), "full")
    advantage = stop - sliding
    assert row.extra["n_sliding_first"] == 5 and row.extra["n_stop_first"] == 5
    assert row.extra["sliding_first_mean"] == pytest.approx(advantage[:5].mean())
    assert row.extra["stop_first_mean"] == pytest.approx(advantage[5:].mean())
    assert row.sliding_mean is None and row.tail == "two-sided"
    assert 0.0 < row.extra["power"] < 1.0
    assert row.extra["verdict"] == ("detected" if row.p < 0.05 else "not detected")
    # A strong learning effect: the second trial 30 % faster.
    learned_stop = np.where(first, stop * 0.7, stop)
    learned_sliding = np.where(first, sliding, sliding * 0.7)
    strong = order_effect(by_participant(_records(learned_sliding, learned_stop, sliding_first=first)), "full")
    assert strong.p < 0.05 and strong.extra["verdict"] == "detected"


def test_descriptive_table_is_mean_sd_median_and_change():
    rng = np.random.default_rng(4)
    stop = rng.normal(40, 6, 8)
    sliding = rng.normal(32, 4, 8)
    rows = {(d.attention, d.label): d for d in describe(_records(sliding, stop))}
    d = rows["full", "completion time [s]"]
    sl, st, change = d.cells()
    assert sl.startswith(f"{sliding.mean():.2f} ± {sliding.std(ddof=1):.2f} (median {np.median(sliding):.2f}, n = 8)")
    assert change == f"{100 * (sliding.mean() / stop.mean() - 1):+.0f} %"
