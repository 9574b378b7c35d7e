"""The supporting model of the attention interaction: a linear mixed model of log time.

``log(completion time) ~ sliding * divided * period + (1 | participant)``: ``sliding`` and
``divided`` are 0/1 indicators (stop, full attention = 0), ``period`` the trial's position in
the participant's session (1-4, centred), a random intercept per participant; fitted by REML
with statsmodels' ``MixedLM``. The ``sliding:divided`` coefficient is the interaction: how much
more (in log time) sliding saves in divided than in full attention; negative = sliding helps
more under divided attention (paper 1's hypothesis), tested one-tailed (``tail="less"``) by its
Wald z (an asymptotic p). ``exp(beta) - 1`` is that extra saving as a fraction.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from cobotsafety.trial.statistics import MIXED_TEST, SLIDING, STOP, Result, attention_change, by_participant

NAME = "attention interaction (mixed model): sliding x divided coefficient on log completion time"
TERM = "sliding:divided"
MIN_PARTICIPANTS = 6
"""Fewer participants: the model is not fitted (8 fixed effects; its Wald test is asymptotic and
anti-conservative in small samples)."""


def model_rows(records: list[dict]) -> list[dict]:
    """One row per finished trial of a participant who finished all four."""
    t = by_participant(records)
    people = None
    for cell in (("full", SLIDING), ("full", STOP), ("divided", SLIDING), ("divided", STOP)):
        have = {p for p, r in t.get(cell, {}).items() if (r.get("completion_time_s") or 0) > 0}
        people = have if people is None else people & have
    rows = []
    for (attention, condition), cell in t.items():
        for p, r in cell.items():
            if p in (people or set()):
                rows.append({"participant": p, "log_time": math.log(r["completion_time_s"]),
                             "sliding": int(condition == SLIDING), "divided": int(attention == "divided"),
                             "period": float(r["order"])})
    return rows


def interaction_model(records: list[dict]) -> Result:
    """The mixed model's interaction as a ``Result`` (``sliding_mean``/``stop_mean``: the mean
    log(divided / full) per condition, what the coefficient contrasts)."""
    change = attention_change(by_participant(records), log=True)
    means = (float(np.mean(list(change[SLIDING].values()))) if change[SLIDING] else None,
             float(np.mean(list(change[STOP].values()))) if change[STOP] else None)
    rows = model_rows(records)
    n = len({r["participant"] for r in rows})
    base = dict(tail="less", role="supporting")
    if n < MIN_PARTICIPANTS:
        return Result(NAME, MIXED_TEST, n, *means, None, None, None,
                      f"too few data: {n} participant(s) with all four trials ({MIN_PARTICIPANTS} needed)", **base)
    import pandas as pd  # noqa: PLC0415
    import statsmodels.formula.api as smf  # noqa: PLC0415
    from scipy.stats import norm  # noqa: PLC0415

    frame = pd.DataFrame(rows)
    frame["period"] -= frame["period"].mean()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fit = smf.mixedlm("log_time ~ sliding * divided * period", frame, groups=frame["participant"]).fit(
                reml=True, method=["lbfgs", "bfgs", "nm"])
        except (ValueError, np.linalg.LinAlgError) as error:
            return Result(NAME, MIXED_TEST, n, *means, None, None, None, f"model not fitted: {error}", **base)
    beta, se = float(fit.params[TERM]), float(fit.bse[TERM])
    if not (np.isfinite(beta) and np.isfinite(se) and se > 0):
        return Result(NAME, MIXED_TEST, n, *means, None, None, None, "model not fitted: no standard error", **base)
    z = beta / se
    low, high = (float(v) for v in fit.conf_int().loc[TERM])
    reason = "" if fit.converged else "the optimiser did not report convergence"
    return Result(NAME, MIXED_TEST, n, *means, float(norm.cdf(z)), beta, (low, high), reason, statistic=z,
                  p_method="asymptotic", extra={"percent": 100.0 * math.expm1(beta), "converged": bool(fit.converged)},
                  **base)
