"""The trial's statistics (paper 1, IV.A-B), from scored records to one result per comparison.

Every participant does every condition, so beside the paper's one-tailed Mann-Whitney-Wilcoxon
test (kept, to compare with the paper; it treats the two conditions as independent groups)
each comparison also gets the paired one-tailed Wilcoxon signed-rank test. Effect sizes are
rank-biserial correlations, positive when they favour sliding (in [-1, 1]): for Mann-Whitney
``2 U_stop / (n1 n2) - 1`` (or its mirror for scores), for the signed-rank test
``(R+ - R-) / (R+ + R-)`` over the per-participant differences. ``ci95`` is a bootstrap 95 %
interval (``scipy.stats.bootstrap``, BCa, 9999 resamples, fixed seed) of the mean difference
sliding - stop: of the paired differences for Wilcoxon, of the two group means for Mann-Whitney.

Comparisons: completion time [s] in full and in divided attention (sliding faster), the
error score [points] in both modes (sliding higher, i.e. fewer points lost), section IV.B's
(divided - full) completion time (sliding's increase smaller), and an order (learning) check:
the per-participant advantage (stop - sliding time) of participants who did sliding first
against those who did stop first (two-sided Mann-Whitney; a learning effect shows as a
difference). A test that cannot run says why in ``reason`` (and ``p`` is None).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import bootstrap, mannwhitneyu, rankdata, wilcoxon

from cobotsafety.trial.scoring import error_score

SLIDING, STOP = "anticipative", "stop"
MWW, WILCOXON = "mann-whitney one-tailed", "wilcoxon signed-rank one-tailed"
ORDER_TEST = "mann-whitney two-sided"
BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_SEED = 12345


@dataclass(frozen=True)
class Result:
    comparison: str
    test: str
    n: int
    """Participants (paired tests, order check) or the smaller group (Mann-Whitney)."""
    sliding_mean: float | None
    stop_mean: float | None
    p: float | None
    effect_size: float | None
    ci95: tuple[float, float] | None
    reason: str = ""
    """Why the test did not run (too few data), else empty."""

    def as_json(self) -> dict:
        return {"comparison": self.comparison, "test": self.test, "n": self.n,
                "sliding_mean": _r(self.sliding_mean), "stop_mean": _r(self.stop_mean), "p": self.p,
                "effect_size": _r(self.effect_size),
                "ci95": None if self.ci95 is None else [_r(self.ci95[0]), _r(self.ci95[1])]}


def _r(x):
    return None if x is None or not np.isfinite(x) else round(float(x), 4) + 0.0  # no -0.0


def _mean(x) -> float | None:
    return float(np.mean(x)) if len(x) else None


def _ci(data: tuple, statistic, with_ci: bool) -> tuple[float, float] | None:
    """Bootstrap 95 % interval (BCa, percentile if BCa is undefined); None when ``with_ci`` is off."""
    if not with_ci:
        return None
    if all(np.ptp(d) == 0 for d in data):  # constant data: the interval is the point
        value = float(statistic(*[np.asarray(d) for d in data]))
        return value, value
    for method in ("BCa", "percentile"):
        with np.errstate(all="ignore"):
            res = bootstrap(data, statistic, confidence_level=0.95, n_resamples=BOOTSTRAP_RESAMPLES, method=method,
                            random_state=np.random.default_rng(BOOTSTRAP_SEED), vectorized=True)
        low, high = res.confidence_interval
        if np.isfinite(low) and np.isfinite(high):
            return float(low), float(high)
    return None


def _mean_stat(d, axis=-1):
    return np.mean(d, axis=axis)


def _diff_stat(a, b, axis=-1):
    return np.mean(a, axis=axis) - np.mean(b, axis=axis)


def mann_whitney(comparison: str, sliding, stop, lower_is_better: bool = True, with_ci: bool = True) -> Result:
    """One-tailed MWW that sliding is better (lower times, or higher scores)."""
    sliding, stop = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    n = min(len(sliding), len(stop))
    means = _mean(sliding), _mean(stop)
    if n < 2:
        return Result(comparison, MWW, n, *means, None, None, None,
                      f"too few data: {len(sliding)} sliding and {len(stop)} stop values (2 per group needed)")
    if np.ptp(np.concatenate([sliding, stop])) == 0:
        return Result(comparison, MWW, n, *means, None, None, _ci((sliding, stop), _diff_stat, with_ci),
                      f"no test possible: all {len(sliding) + len(stop)} values are equal")
    alternative = "less" if lower_is_better else "greater"
    res = mannwhitneyu(sliding, stop, alternative=alternative)
    u_sliding = float(res.statistic)
    rbc = 1.0 - 2.0 * u_sliding / (len(sliding) * len(stop))
    effect = rbc if lower_is_better else -rbc
    return Result(comparison, MWW, n, *means, float(res.pvalue), effect, _ci((sliding, stop), _diff_stat, with_ci))


def signed_rank(comparison: str, sliding, stop, lower_is_better: bool = True, with_ci: bool = True) -> Result:
    """Paired one-tailed Wilcoxon signed-rank that sliding is better; pairs are aligned."""
    sliding, stop = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    n = len(sliding)
    means = _mean(sliding), _mean(stop)
    gain = (stop - sliding) if lower_is_better else (sliding - stop)  # > 0 favours sliding
    nonzero = gain[gain != 0.0]
    ci = _ci((sliding - stop,), _mean_stat, with_ci) if n >= 2 else None
    if n < 2 or len(nonzero) < 1:
        why = (f"too few data: {n} participant(s) with both conditions (2 needed)" if n < 2 else
               f"no test possible: all {n} paired differences are zero")
        return Result(comparison, WILCOXON, n, *means, None, None, ci, why)
    res = wilcoxon(gain, alternative="greater", zero_method="wilcox")
    ranks = rankdata(np.abs(nonzero))
    effect = float((ranks[nonzero > 0].sum() - ranks[nonzero < 0].sum()) / ranks.sum())
    reason = ""
    if len(nonzero) < 5:
        reason = (f"{len(nonzero)} non-zero pair(s): the smallest possible one-tailed p is "
                  f"{0.5 ** len(nonzero):.3g}, so this test cannot reach 0.05")
    return Result(comparison, WILCOXON, n, *means, float(res.pvalue), effect, ci, reason)


def by_participant(records: list[dict]) -> dict:
    """{(attention, condition): {participant: record}}."""
    out: dict = {}
    for r in records:
        out.setdefault((r["attention"], r["condition"]), {})[r["participant"]] = r
    return out


def _paired(t: dict, attention: str, value) -> tuple[list, np.ndarray, np.ndarray]:
    sl, st = t.get((attention, SLIDING), {}), t.get((attention, STOP), {})
    ids = sorted(p for p in set(sl) & set(st) if value(sl[p]) is not None and value(st[p]) is not None)
    return ids, np.array([value(sl[p]) for p in ids], float), np.array([value(st[p]) for p in ids], float)


def _group(t: dict, attention: str, condition: str, value) -> np.ndarray:
    return np.array([v for r in t.get((attention, condition), {}).values() if (v := value(r)) is not None], float)


def completion(record: dict):
    return record.get("completion_time_s")


def score(record: dict):
    return float(error_score(record))


def compare_all(records: list[dict], with_ci: bool = True) -> list[Result]:
    """Every comparison, each with the paper's MWW and the paired signed-rank test."""
    t = by_participant(records)
    results: list[Result] = []
    for attention in ("full", "divided"):
        for label, value, lower in (("completion time [s]", completion, True), ("error score [points]", score, False)):
            name = f"{attention} attention: {label}"
            results.append(mann_whitney(name, _group(t, attention, SLIDING, value), _group(t, attention, STOP, value),
                                        lower, with_ci))
            _, sl, st = _paired(t, attention, value)
            results.append(signed_rank(name, sl, st, lower, with_ci))
    # IV.B: (divided - full) completion time per participant, sliding vs stop.
    increase = {}
    for condition in (SLIDING, STOP):
        full, divided = t.get(("full", condition), {}), t.get(("divided", condition), {})
        increase[condition] = {p: divided[p]["completion_time_s"] - full[p]["completion_time_s"]
                               for p in full if p in divided and full[p]["completion_time_s"] is not None
                               and divided[p]["completion_time_s"] is not None}
    name = "divided - full completion time [s]"
    results.append(mann_whitney(name, list(increase[SLIDING].values()), list(increase[STOP].values()),
                                with_ci=with_ci))
    ids = sorted(set(increase[SLIDING]) & set(increase[STOP]))
    results.append(signed_rank(name, [increase[SLIDING][p] for p in ids], [increase[STOP][p] for p in ids],
                               with_ci=with_ci))
    for attention in ("full", "divided"):
        results.append(order_effect(t, attention, with_ci))
    return results


def order_effect(t: dict, attention: str, with_ci: bool = True) -> Result:
    """Does the sliding advantage depend on which condition came first (learning)?"""
    name = f"order effect, {attention} attention: advantage (stop - sliding time) [s], sliding first vs stop first"
    ids, sl, st = _paired(t, attention, completion)
    sliding_first = np.array([t[(attention, SLIDING)][p]["order"] < t[(attention, STOP)][p]["order"] for p in ids], bool)
    advantage = st - sl
    first, second = advantage[sliding_first], advantage[~sliding_first]
    means = _mean(sl), _mean(st)
    n = len(ids)
    if len(first) < 2 or len(second) < 2:
        return Result(name, ORDER_TEST, n, *means, None, None, None,
                      f"too few data: {len(first)} sliding-first and {len(second)} stop-first participants (2 each needed)")
    res = mannwhitneyu(first, second, alternative="two-sided")
    effect = 2.0 * float(res.statistic) / (len(first) * len(second)) - 1.0
    return Result(name, ORDER_TEST, n, *means, float(res.pvalue), effect, _ci((first, second), _diff_stat, with_ci))
