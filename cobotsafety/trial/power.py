"""Power: how often each comparison comes out significant with N participants.

``power(studies)`` runs ``comparisons.compare_all`` (without bootstrap intervals) on each study's
records and counts, per comparison and test, the studies whose decision p (Holm-adjusted where
the comparison is in a family, else the raw p) is below alpha; a test that cannot run counts as
not significant. ``simulated_power(N, K)`` feeds it K studies of N simulated participants
(``cobotsafety trial --simulate N --repeat K``; ``overrides`` sets parameter ranges, ``--vary``).
The simulated participant is a model (see ``simulated_participant``): the numbers plan a study
and show what the model's assumptions imply, they are not evidence.
``paper_power(N, K)`` (``--paper-effect``) draws the studies from paper 1's own means and SDs
instead (IV.A-B: times normal, colour errors Poisson with the reported mean scores), each value
independent (the paper gives no within-person correlation, so pairing gains nothing here: a
conservative estimate for the paired test).
``sensitivity(N, K, vary)`` repeats ``simulated_power`` with one parameter set to each of a few
values at a time (``--vary NAME=LO:HI``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from cobotsafety.trial.comparisons import compare_all


@dataclass(frozen=True)
class PowerRow:
    comparison: str
    test: str
    participants: int
    studies: int
    power: float
    """Fraction of the studies with p < alpha."""
    median_p: float | None
    mean_sliding: float | None
    mean_stop: float | None
    role: str = ""

    def as_json(self) -> dict:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def power(studies: Iterable[list[dict]], alpha: float = 0.05) -> list[PowerRow]:
    """One row per (comparison, test), in ``compare_all``'s order."""
    per_key: dict = {}
    n_studies = 0
    participants = 0
    for records in studies:
        n_studies += 1
        participants = max(participants, len({r["participant"] for r in records}))
        for r in compare_all(records, with_ci=False, order_power=False):
            per_key.setdefault((r.comparison, r.test), []).append(r)
    rows = []
    for (comparison, test), results in per_key.items():
        ps = [r.p for r in results if r.p is not None]
        significant = sum(1 for r in results if r.p is not None
                          and (r.p_holm if r.p_holm is not None else r.p) < alpha)
        means = [(r.sliding_mean, r.stop_mean) for r in results if r.sliding_mean is not None and r.stop_mean is not None]
        rows.append(PowerRow(comparison, test, participants, n_studies, significant / n_studies,
                             float(np.median(ps)) if ps else None,
                             float(np.mean([m[0] for m in means])) if means else None,
                             float(np.mean([m[1] for m in means])) if means else None, results[0].role))
    return rows


def simulated_power(participants: int, repeat: int, seed: int = 0, scene: str = "planar",
                    alpha: float = 0.05, overrides: dict[str, tuple[float, float]] | None = None) -> list[PowerRow]:
    """``repeat`` simulated studies of ``participants`` each (study k uses seed ``seed + k``)."""
    return power(simulated_studies(participants, repeat, seed, scene, overrides), alpha)


def simulated_studies(participants: int, repeat: int, seed: int = 0, scene: str = "planar",
                      overrides: dict[str, tuple[float, float]] | None = None):
    """The records of ``repeat`` simulated studies (a generator of lists)."""
    from cobotsafety.trial.simulate import simulated_study  # noqa: PLC0415

    for k in range(repeat):
        yield [record for record, _ in simulated_study(participants, seed + k, scene, overrides=overrides)]


#: Paper 1's completion times (mean, SD) [s] and mean error scores [points], IV.A-B.
PAPER_TIMES_S = {("full", "stop"): (40.0, 6.3), ("full", "anticipative"): (31.9, 3.8),
                 ("divided", "stop"): (63.4, 9.3), ("divided", "anticipative"): (43.2, 3.93)}
PAPER_DIVIDED_SCORES = {"stop": -4.7, "anticipative": -0.9}


def paper_study(participants: int, seed: int) -> list[dict]:
    """Records of one study drawn from the paper's numbers, in ``plan.session_plan``'s
    counterbalanced orders (conditions and attention modes)."""
    from cobotsafety.trial.plan import session_plan  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    ids = [f"P{i + 1:02d}" for i in range(participants)]
    order = {(t.participant, t.attention, t.condition): t.order for t in session_plan(ids, seed=seed)}
    records = []
    for participant in ids:
        for (attention, condition), (mean, sd) in PAPER_TIMES_S.items():
            lost = int(rng.poisson(-PAPER_DIVIDED_SCORES[condition])) if attention == "divided" else 0
            records.append({"participant": participant, "condition": condition, "attention": attention,
                            "order": order[participant, attention, condition],
                            "completion_time_s": float(rng.normal(mean, sd)),
                            "errors": [{"kind": "wrong", "t_s": 0.0, "points": -1}] * lost})
    return records


def paper_power(participants: int, repeat: int, seed: int = 0, alpha: float = 0.05) -> list[PowerRow]:
    """``repeat`` studies of ``participants`` drawn from the paper's means and SDs."""
    return power((paper_study(participants, seed + k) for k in range(repeat)), alpha)


def table(rows: list[PowerRow], alpha: float = 0.05) -> str:
    if not rows:
        return "no studies"
    head = (f"Power with {rows[0].participants} participants over {rows[0].studies} simulated studies "
            f"(share of studies with p < {alpha}):")
    lines = [head, "", "| comparison | test | power | median p | sliding mean | stop mean |", "|---|---|---|---|---|---|"]
    for r in rows:
        fmt = lambda x, d=2: "-" if x is None else f"{x:.{d}f}"  # noqa: E731
        lines.append(f"| {r.comparison} | {r.test} | {100 * r.power:.0f} % | {'-' if r.median_p is None else f'{r.median_p:.2g}'} | "
                     f"{fmt(r.mean_sliding)} | {fmt(r.mean_stop)} |")
    return "\n".join(lines)
