"""The rank tests of the trial analysis, each returning its statistic, p, and how p was obtained.

* ``mann_whitney_test(sliding, stop, tail)``: ``U`` is scipy's statistic of the first sample
  (sliding): the pairs in which sliding is larger, ties counting one half. Without ties p is
  scipy's exact null distribution; with ties, the exact conditional distribution over every
  split of the pooled midranks, counted by ``_split_counts`` (the number of splits with each
  rank sum, built one value at a time: the classical exact method for tied data, equal to
  enumerating every split with ``scipy.stats.permutation_test``, which the tests do); with
  more than ``MAX_EXACT_N`` values, the normal approximation (tie and continuity corrected),
  the one paper 1's p = 0.00009 comes from.
* ``signed_rank_test(sliding, stop, tail)``: differences ``sliding - stop``, zeros dropped
  (Wilcoxon's rule); ``W`` is scipy's statistic for a one-sided test, the rank sum of the
  positive differences (for two-sided tests scipy reports the smaller rank sum; so does this).
  Exact without ties (scipy), exact over every sign flip with ties (``_flip_counts``), up to
  ``MAX_EXACT_N`` differences, else asymptotic.

Two-sided exact p-values are twice the smaller one-sided p (at most 1), as scipy's.

``tail`` is scipy's ``alternative`` in the direction sliding - stop: ``"less"`` (sliding lower,
e.g. faster), ``"greater"`` or ``"two-sided"``. Each returns ``RankTest(statistic, p, method)``
with ``method`` ``"exact"`` or ``"asymptotic"``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.stats import mannwhitneyu, rankdata, wilcoxon

TAILS = ("less", "greater", "two-sided")
#: Largest sample (pooled values, or non-zero differences) given an exact p with ties.
MAX_EXACT_N = 200


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
    if len(pooled) <= MAX_EXACT_N:
        doubled = np.rint(2.0 * rankdata(pooled)).astype(int)  # midranks are halves: integers when doubled
        counts = _split_counts(doubled, len(x))
        return RankTest(u, _tail_p(counts, int(doubled[:len(x)].sum()), tail), "exact")
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
    if len(d) <= MAX_EXACT_N:
        doubled = np.rint(2.0 * rankdata(np.abs(d))).astype(int)
        counts = _flip_counts(doubled)
        return RankTest(statistic, _tail_p(counts, int(doubled[d > 0].sum()), tail), "exact")
    res = wilcoxon(d, alternative=tail, method="approx", correction=True)
    return RankTest(statistic, float(res.pvalue), "asymptotic")


def _split_counts(values: np.ndarray, size: int) -> np.ndarray:
    """``counts[s]``: how many subsets of ``size`` of the integer ``values`` sum to ``s``."""
    total = int(values.sum())
    table = np.zeros((size + 1, total + 1))
    table[0, 0] = 1.0
    for v in values:
        table[1:, v:] = table[1:, v:] + table[:-1, :total + 1 - v]
    return table[size]


def _flip_counts(values: np.ndarray) -> np.ndarray:
    """``counts[s]``: how many sign assignments of the integer ``values`` give a positive sum ``s``."""
    total = int(values.sum())
    counts = np.zeros(total + 1)
    counts[0] = 1.0
    for v in values:
        counts[v:] = counts[v:] + counts[:total + 1 - v]
    return counts


def _tail_p(counts: np.ndarray, observed: int, tail: str) -> float:
    """The p of ``observed`` under the null distribution ``counts`` (index = statistic)."""
    cdf = np.cumsum(counts) / counts.sum()
    less = float(cdf[observed])
    greater = float(1.0 - (cdf[observed - 1] if observed > 0 else 0.0))
    if tail == "less":
        return less
    if tail == "greater":
        return greater
    return min(1.0, 2.0 * min(less, greater))
