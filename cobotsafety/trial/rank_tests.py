"""The rank tests of the trial analysis, each returning its statistic, p, and how p was obtained.

* ``mann_whitney_test(sliding, stop, tail)``: ``U`` is scipy's statistic of the first sample
  (sliding): the pairs in which sliding is larger, ties counting one half. Without ties p is
  scipy's exact null distribution; with ties, the exact conditional distribution over every
  split of the pooled ranks (``scipy.stats.permutation_test``), as long as there are at most
  ``MAX_EXACT_ARRANGEMENTS`` splits; else the normal approximation (tie and continuity
  corrected), the one paper 1's p = 0.00009 comes from.
* ``signed_rank_test(sliding, stop, tail)``: differences ``sliding - stop``, zeros dropped
  (Wilcoxon's rule); ``W`` is scipy's statistic for a one-sided test, the rank sum of the
  positive differences (for two-sided tests scipy reports the smaller rank sum; so does this).
  Exact without ties (scipy), exact over every sign flip with ties (up to
  ``MAX_EXACT_ARRANGEMENTS``), else asymptotic.

``tail`` is scipy's ``alternative`` in the direction sliding - stop: ``"less"`` (sliding lower,
e.g. faster), ``"greater"`` or ``"two-sided"``. Each returns ``RankTest(statistic, p, method)``
with ``method`` ``"exact"`` or ``"asymptotic"``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.stats import mannwhitneyu, permutation_test, rankdata, wilcoxon

TAILS = ("less", "greater", "two-sided")
#: Largest number of arrangements enumerated for an exact p with ties.
MAX_EXACT_ARRANGEMENTS = 250_000


class RankTest(NamedTuple):
    statistic: float
    p: float
    method: str
    """``"exact"`` or ``"asymptotic"``."""


def _check_tail(tail: str) -> None:
    if tail not in TAILS:
        raise ValueError(f"tail must be one of {TAILS}, got {tail!r}")


def mann_whitney_test(sliding, stop, tail: str) -> RankTest:
    """Mann-Whitney U test of ``sliding`` against ``stop`` (1-D samples, at least one each)."""
    _check_tail(tail)
    x, y = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    pooled = np.concatenate([x, y])
    u = float(mannwhitneyu(x, y, alternative=tail, method="asymptotic").statistic)
    if len(np.unique(pooled)) == len(pooled):
        return RankTest(u, float(mannwhitneyu(x, y, alternative=tail, method="exact").pvalue), "exact")
    if math.comb(len(pooled), len(x)) <= MAX_EXACT_ARRANGEMENTS:
        ranks = rankdata(pooled)
        offset = len(x) * (len(x) + 1) / 2.0

        def u_of(rx, ry, axis=-1):
            return np.sum(rx, axis=axis) - offset

        res = permutation_test((ranks[:len(x)], ranks[len(x):]), u_of, permutation_type="independent",
                               alternative=tail, n_resamples=np.inf, vectorized=True)
        return RankTest(u, float(min(res.pvalue, 1.0)), "exact")
    res = mannwhitneyu(x, y, alternative=tail, method="asymptotic", use_continuity=True)
    return RankTest(u, float(res.pvalue), "asymptotic")


def signed_rank_test(sliding, stop, tail: str) -> RankTest:
    """Wilcoxon signed-rank test of the paired differences ``sliding - stop`` (one non-zero
    difference at least)."""
    _check_tail(tail)
    d = np.asarray(sliding, dtype=float) - np.asarray(stop, dtype=float)
    d = d[d != 0.0]
    if len(d) == 0:
        raise ValueError("every paired difference is zero")
    ties = len(np.unique(np.abs(d))) < len(d)
    if not ties:
        res = wilcoxon(d, alternative=tail, method="exact")
        return RankTest(float(res.statistic), float(res.pvalue), "exact")
    statistic = float(wilcoxon(d, alternative=tail, method="approx").statistic)
    if 2 ** len(d) <= MAX_EXACT_ARRANGEMENTS:
        signed = rankdata(np.abs(d)) * np.sign(d)

        def r_plus(s, axis=-1):
            return np.sum(np.where(s > 0, s, 0.0), axis=axis)

        res = permutation_test((signed,), r_plus, permutation_type="samples", alternative=tail,
                               n_resamples=np.inf, vectorized=True)
        return RankTest(statistic, float(min(res.pvalue, 1.0)), "exact")
    res = wilcoxon(d, alternative=tail, method="approx", correction=True)
    return RankTest(statistic, float(res.pvalue), "asymptotic")
