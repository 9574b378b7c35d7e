"""The trial's statistics (paper 1, IV.A-B), from scored records to one result per comparison.

The analysis is the one declared in ``plan.ANALYSIS`` (and written to ``plan.json`` before the
first trial):

* **Primary**: completion time, sliding vs stop, in each attention mode, with the paired
  one-tailed Wilcoxon signed-rank test (every participant drives both conditions) and, to
  compare with paper 1, its one-tailed Mann-Whitney test (independent groups). Holm over the
  two attention modes, per test (``p_holm``).
* **Secondary** (Holm over them, per test): the error score in both modes; colour errors per
  scored word in divided attention (longer trials show more words, so a per-trial count would
  penalise slowness twice); the attention interaction on log time, ``log(divided / full)`` per
  participant, sliding vs stop (a slowdown in proportion, not in seconds: divided attention
  slows both conditions, so absolute differences mix the interaction with the scale); paper
  1's own IV.B comparison of ``divided - full`` in seconds; the median colour response time.
* **Supporting**: a linear mixed model of log completion time (``mixed_model``).
* **Checks**: the order check, reported as "detected" or "not detected" with its power.

Every p says how it was obtained (``p_method``: exact or asymptotic; see ``rank_tests``) and its
``tail`` in the direction sliding - stop; ``statistic`` is U or W as scipy defines them.
Effect sizes are rank-biserial correlations, positive when they favour sliding. ``ci95`` is a
bootstrap 95 % interval (``scipy.stats.bootstrap``, BCa, 9999 resamples, fixed seed) of the
mean difference sliding - stop: of the paired differences for Wilcoxon, of the two group means
for Mann-Whitney. A test that cannot run says why in ``reason`` (``p`` None).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import bootstrap, mannwhitneyu, rankdata

from cobotsafety.trial.rank_tests import mann_whitney_test, signed_rank_test
from cobotsafety.trial.scoring import error_score

SLIDING, STOP = "anticipative", "stop"
MWW, WILCOXON = "mann-whitney one-tailed", "wilcoxon signed-rank one-tailed"
ORDER_TEST = "mann-whitney two-sided"
MIXED_TEST = "linear mixed model (REML), Wald z one-tailed"
BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_SEED = 12345
ALPHA = 0.05
#: The learning effect the order check's power is computed for: a participant's second trial
#: in an attention mode this fraction faster than the first.
ORDER_LEARNING = 0.10
ORDER_POWER_DRAWS = 1000

TIME = "completion time [s]"
SCORE = "error score [points]"
PER_WORD = "colour errors per scored word"
LOG_INTERACTION = "attention interaction: log(divided / full) completion time"
ABS_INTERACTION = "divided - full completion time [s] (paper 1's IV.B comparison)"
RESPONSE = "median colour response time [s]"


@dataclass(frozen=True)
class Result:
    comparison: str
    test: str
    n: int
    """Participants (paired tests, order check, mixed model) or the smaller group (Mann-Whitney)."""
    sliding_mean: float | None
    stop_mean: float | None
    p: float | None
    effect_size: float | None
    ci95: tuple[float, float] | None
    reason: str = ""
    """Why the test did not run (too few data), or what limits it; else empty."""
    statistic: float | None = None
    """U (Mann-Whitney, of the sliding sample), W (signed-rank, scipy's), z (mixed model)."""
    p_method: str | None = None
    """``"exact"`` or ``"asymptotic"``."""
    tail: str | None = None
    """``"less"``, ``"greater"`` or ``"two-sided"``, in the direction sliding - stop."""
    p_holm: float | None = None
    """Holm-adjusted p within the result's family (primary or secondary, per test); None elsewhere."""
    role: str = ""
    """``primary``, ``secondary``, ``supporting`` or ``check``."""
    extra: dict = field(default_factory=dict)
    """Further quantities the p-value is about (order check: the two groups; mixed model: the
    coefficient), printed in the JSON beside the standard keys."""

    def as_json(self) -> dict:
        out = {"comparison": self.comparison, "test": self.test, "n": self.n,
               "sliding_mean": _r(self.sliding_mean), "stop_mean": _r(self.stop_mean), "p": self.p,
               "effect_size": _r(self.effect_size),
               "ci95": None if self.ci95 is None else [_r(self.ci95[0]), _r(self.ci95[1])],
               "statistic": _r(self.statistic), "p_method": self.p_method, "tail": self.tail,
               "p_holm": self.p_holm, "role": self.role}
        out.update({k: (_r(v) if isinstance(v, float) else v) for k, v in self.extra.items()})
        return out


def _r(x):
    return None if x is None or not np.isfinite(x) else round(float(x), 6) + 0.0  # no -0.0


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
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
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


def _favour(tail: str) -> float:
    """+1 when a lower sliding value favours sliding (``less``), -1 for ``greater``."""
    return -1.0 if tail == "greater" else 1.0


def mann_whitney(comparison: str, sliding, stop, tail: str = "less", with_ci: bool = True,
                 role: str = "") -> Result:
    """Mann-Whitney test of sliding against stop in the direction ``tail`` (sliding - stop)."""
    sliding, stop = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    n = min(len(sliding), len(stop))
    means = _mean(sliding), _mean(stop)
    test = MWW if tail != "two-sided" else ORDER_TEST
    base = dict(tail=tail, role=role)
    if n < 2:
        return Result(comparison, test, n, *means, None, None, None,
                      f"too few data: {len(sliding)} sliding and {len(stop)} stop values (2 per group needed)", **base)
    if np.ptp(np.concatenate([sliding, stop])) == 0:
        return Result(comparison, test, n, *means, None, None, _ci((sliding, stop), _diff_stat, with_ci),
                      f"no test possible: all {len(sliding) + len(stop)} values are equal", **base)
    res = mann_whitney_test(sliding, stop, tail)
    effect = _favour(tail) * (1.0 - 2.0 * res.statistic / (len(sliding) * len(stop)))
    return Result(comparison, test, n, *means, res.p, effect, _ci((sliding, stop), _diff_stat, with_ci),
                  statistic=res.statistic, p_method=res.method, **base)


def signed_rank(comparison: str, sliding, stop, tail: str = "less", with_ci: bool = True,
                role: str = "") -> Result:
    """Paired Wilcoxon signed-rank test of ``sliding - stop`` (pairs aligned) in the direction ``tail``."""
    sliding, stop = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    n = len(sliding)
    means = _mean(sliding), _mean(stop)
    d = sliding - stop
    nonzero = d[d != 0.0]
    ci = _ci((d,), _mean_stat, with_ci) if n >= 2 else None
    base = dict(tail=tail, role=role)
    if n < 2 or len(nonzero) < 1:
        why = (f"too few data: {n} participant(s) with both conditions (2 needed)" if n < 2 else
               f"no test possible: all {n} paired differences are zero")
        return Result(comparison, WILCOXON, n, *means, None, None, ci, why, **base)
    res = signed_rank_test(sliding, stop, tail)
    ranks = rankdata(np.abs(nonzero))
    toward = -_favour(tail) * nonzero  # > 0 favours sliding
    effect = float((ranks[toward > 0].sum() - ranks[toward < 0].sum()) / ranks.sum())
    reason = ""
    if len(nonzero) < 5:
        reason = (f"{len(nonzero)} non-zero pair(s): the smallest possible one-tailed p is "
                  f"{0.5 ** len(nonzero):.3g}, so this test cannot reach 0.05")
    return Result(comparison, WILCOXON, n, *means, res.p, effect, ci, reason, statistic=res.statistic,
                  p_method=res.method, **base)


# ---- values per record ---------------------------------------------------------------------
def by_participant(records: list[dict]) -> dict:
    """{(attention, condition): {participant: record}} (skipped trials left out)."""
    out: dict = {}
    for r in records:
        if r.get("skipped"):
            continue
        out.setdefault((r["attention"], r["condition"]), {})[r["participant"]] = r
    return out


def completion(record: dict):
    return record.get("completion_time_s")


def score(record: dict):
    return float(error_score(record))


def scored_words(record: dict) -> int | None:
    """Colour words that count in ``record`` (None for records without their stimuli)."""
    stimuli = record.get("stimuli")
    return None if stimuli is None else sum(1 for s in stimuli if s.get("scored"))


def colour_errors(record: dict, kind: str | None = None) -> int:
    """Scored colour errors (``kind`` ``missed`` or ``wrong``; None: both)."""
    from cobotsafety.trial.scoring import COLOUR_KINDS, scored_errors  # noqa: PLC0415

    kinds = COLOUR_KINDS if kind is None else (kind,)
    return sum(1 for e in scored_errors(record) if e.get("kind") in kinds)


def errors_per_word(record: dict, kind: str | None = None):
    words = scored_words(record)
    return None if not words else colour_errors(record, kind) / words


def median_response(record: dict):
    times = record.get("response_times_s") or []
    return float(np.median(times)) if len(times) else None


def _paired(t: dict, attention: str, value) -> tuple[list, np.ndarray, np.ndarray]:
    sl, st = t.get((attention, SLIDING), {}), t.get((attention, STOP), {})
    ids = sorted(p for p in set(sl) & set(st) if value(sl[p]) is not None and value(st[p]) is not None)
    return ids, np.array([value(sl[p]) for p in ids], float), np.array([value(st[p]) for p in ids], float)


def _group(t: dict, attention: str, condition: str, value) -> np.ndarray:
    return np.array([v for r in t.get((attention, condition), {}).values() if (v := value(r)) is not None], float)


def _both(name: str, t: dict, attention: str, value, tail: str, with_ci: bool, role: str) -> list[Result]:
    _, sl, st = _paired(t, attention, value)
    return [mann_whitney(name, _group(t, attention, SLIDING, value), _group(t, attention, STOP, value), tail,
                         with_ci, role),
            signed_rank(name, sl, st, tail, with_ci, role)]


def attention_change(t: dict, log: bool) -> dict[str, dict[str, float]]:
    """Per condition, per participant: divided - full completion time [s], or its log ratio."""
    out: dict[str, dict[str, float]] = {}
    for condition in (SLIDING, STOP):
        full, divided = t.get(("full", condition), {}), t.get(("divided", condition), {})
        out[condition] = {}
        for p in full:
            a, b = completion(full[p]), completion(divided.get(p, {}))
            if a is not None and b is not None and a > 0 and b > 0:
                out[condition][p] = math.log(b / a) if log else b - a
    return out


def _interaction(name: str, t: dict, log: bool, with_ci: bool) -> list[Result]:
    change = attention_change(t, log)
    ids = sorted(set(change[SLIDING]) & set(change[STOP]))
    return [mann_whitney(name, list(change[SLIDING].values()), list(change[STOP].values()), "less", with_ci,
                         "secondary"),
            signed_rank(name, [change[SLIDING][p] for p in ids], [change[STOP][p] for p in ids], "less", with_ci,
                        "secondary")]


def holm(results: list[Result]) -> list[Result]:
    """``p_holm`` for every primary and secondary result, Holm within (role, test); results
    without a p stay out of the family (and keep ``p_holm`` None)."""
    from dataclasses import replace  # noqa: PLC0415

    from statsmodels.stats.multitest import multipletests  # noqa: PLC0415

    out = list(results)
    families: dict[tuple[str, str], list[int]] = {}
    for i, r in enumerate(results):
        if r.role in ("primary", "secondary") and r.p is not None:
            families.setdefault((r.role, r.test), []).append(i)
    for members in families.values():
        adjusted = multipletests([results[i].p for i in members], method="holm")[1]
        for i, p in zip(members, adjusted):
            out[i] = replace(results[i], p_holm=float(p))
    return out


def order_effect(t: dict, attention: str, with_ci: bool = True, with_power: bool = True) -> Result:
    """Does the sliding advantage depend on which condition came first (learning, carry-over)?

    Two-sided Mann-Whitney of the advantage (stop - sliding time) [s] of sliding-first against
    stop-first participants. ``extra`` carries the two groups' sizes and mean advantages (what
    the p is about) and ``power``: the share of ``ORDER_POWER_DRAWS`` resampled studies (the
    observed participants' time pairs drawn with replacement into groups of the observed sizes,
    each participant's second trial made ``ORDER_LEARNING`` faster) in which this test gives
    p < 0.05. A p >= 0.05 means "not detected", not "absent"."""
    name = f"order check, {attention} attention: advantage (stop - sliding time) [s], sliding first vs stop first"
    ids, sl, st = _paired(t, attention, completion)
    sliding_first = np.array([t[(attention, SLIDING)][p]["order"] < t[(attention, STOP)][p]["order"] for p in ids],
                             bool)
    advantage = st - sl
    first, second = advantage[sliding_first], advantage[~sliding_first]
    extra = {"n_sliding_first": int(len(first)), "n_stop_first": int(len(second)),
             "sliding_first_mean": _mean(first), "stop_first_mean": _mean(second)}
    n = len(ids)
    if len(first) < 2 or len(second) < 2:
        return Result(name, ORDER_TEST, n, None, None, None, None, None,
                      f"too few data: {len(first)} sliding-first and {len(second)} stop-first participants "
                      "(2 each needed)", tail="two-sided", role="check", extra=extra)
    res = mann_whitney_test(first, second, "two-sided")
    effect = 2.0 * res.statistic / (len(first) * len(second)) - 1.0
    if with_power:
        extra["power"] = order_power(sl, st, len(first), len(second))
        extra["power_for"] = f"second trial of a mode {100 * ORDER_LEARNING:.0f} % faster"
    detected = "detected" if res.p < ALPHA else "not detected"
    extra["verdict"] = detected
    return Result(name, ORDER_TEST, n, None, None, res.p, effect, _ci((first, second), _diff_stat, with_ci),
                  statistic=res.statistic, p_method=res.method, tail="two-sided", role="check", extra=extra)


def order_power(sliding_s: np.ndarray, stop_s: np.ndarray, n_sliding_first: int, n_stop_first: int,
                learning: float = ORDER_LEARNING, draws: int = ORDER_POWER_DRAWS, seed: int = 7) -> float:
    """Power of the order check for a learning effect of ``learning`` (see ``order_effect``)."""
    rng = np.random.default_rng(seed)
    n = len(sliding_s)
    pick_a = rng.integers(0, n, size=(draws, n_sliding_first))
    pick_b = rng.integers(0, n, size=(draws, n_stop_first))
    # Sliding first: stop is the second trial; stop first: sliding is.
    adv_a = stop_s[pick_a] * (1.0 - learning) - sliding_s[pick_a]
    adv_b = stop_s[pick_b] - sliding_s[pick_b] * (1.0 - learning)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = mannwhitneyu(adv_a, adv_b, axis=1, alternative="two-sided", method="asymptotic").pvalue
    return float(np.mean(np.nan_to_num(p, nan=1.0) < ALPHA))


# ---- descriptive tables --------------------------------------------------------------------
@dataclass(frozen=True)
class Describe:
    attention: str
    label: str
    sliding: np.ndarray
    stop: np.ndarray

    def cells(self) -> tuple[str, str, str]:
        def one(x):
            if len(x) == 0:
                return "-"
            sd = f" ± {np.std(x, ddof=1):.2f}" if len(x) > 1 else ""
            return f"{np.mean(x):.2f}{sd} (median {np.median(x):.2f}, n = {len(x)})"

        change = "-"
        if len(self.sliding) and len(self.stop) and np.mean(self.stop) != 0:
            change = f"{100 * (np.mean(self.sliding) / np.mean(self.stop) - 1):+.0f} %"
        return one(self.sliding), one(self.stop), change


def describe(records: list[dict]) -> list[Describe]:
    """Mean ± SD, median and % change (sliding vs stop) of every outcome per attention mode."""
    t = by_participant(records)
    rows = []
    for attention in ("full", "divided"):
        for label, value in ((TIME, completion), (SCORE, score), ("missed words per scored word",
                                                                   lambda r: errors_per_word(r, "missed")),
                             ("wrong answers per scored word", lambda r: errors_per_word(r, "wrong")),
                             ("triangles touched per trial",
                              lambda r: sum(1 for e in r.get("errors", []) if e.get("kind") == "obstacle")),
                             (RESPONSE, median_response)):
            sl, st = _group(t, attention, SLIDING, value), _group(t, attention, STOP, value)
            if len(sl) or len(st):
                rows.append(Describe(attention, label, sl, st))
    return rows
