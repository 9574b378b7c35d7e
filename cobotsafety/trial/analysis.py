"""Analysis of trial logs (paper 1, IV.A-B): times, error scores, one-tailed Mann-Whitney-Wilcoxon.

``analyze(directory, out)`` writes ``report.md`` and PNGs like Figs. 7 and 8: completion time
per participant and condition with group means; error scores; one-tailed tests that sliding is
faster (and scores better) than stop, in each attention mode; and section IV.B's comparison of
(divided - full) completion time between the conditions.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu

from cobotsafety.trial.log_store import load

SLIDING, STOP = "anticipative", "stop"


@dataclass
class Comparison:
    label: str
    sliding: np.ndarray
    stop: np.ndarray
    p_value: float
    """One-tailed: sliding < stop."""

    @property
    def reduction(self) -> float:
        return 1.0 - float(np.mean(self.sliding) / np.mean(self.stop))


def one_tailed_less(a, b) -> float:
    return float(mannwhitneyu(a, b, alternative="less").pvalue)


def compare(label: str, sliding, stop) -> Comparison:
    sliding, stop = np.asarray(sliding, dtype=float), np.asarray(stop, dtype=float)
    return Comparison(label, sliding, stop, one_tailed_less(sliding, stop))


def table(records: list[dict]) -> dict:
    """{(attention, condition): {participant: record}}."""
    out: dict = {}
    for r in records:
        out.setdefault((r["attention"], r["condition"]), {})[r["participant"]] = r
    return out


def analyze(directory: Path, out: Path | None = None) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    out = Path(out) if out is not None else directory / "report"
    out.mkdir(parents=True, exist_ok=True)
    loaded = load(directory)
    t = table(loaded.records)
    lines = ["# Trial report", "", f"Log: `{directory}` — {len(loaded.records)} trials."]
    if loaded.problems:
        lines += ["", "## Problems in the logs (the rest was analysed)", ""] + [f"- {p}" for p in loaded.problems]
    comparisons = []
    for attention in ("full", "divided"):
        sl, st = t.get((attention, SLIDING), {}), t.get((attention, STOP), {})
        times_sl = [r["completion_time_s"] for r in sl.values() if r["completion_time_s"] is not None]
        times_st = [r["completion_time_s"] for r in st.values() if r["completion_time_s"] is not None]
        if len(times_sl) >= 2 and len(times_st) >= 2:
            c = compare(f"{attention} attention: completion time [s]", times_sl, times_st)
            comparisons.append(c)
            fig, ax = plt.subplots(figsize=(6, 3.5))
            participants = sorted(set(sl) | set(st))
            x = np.arange(len(participants))
            for marker, data, name in (("x", sl, "sliding"), ("o", st, "stop")):
                ax.scatter(x, [data[p]["completion_time_s"] if p in data and data[p]["completion_time_s"] else np.nan for p in participants],
                           marker=marker, label=name)
            ax.axhline(np.mean(times_sl), ls="--", color="C0")
            ax.axhline(np.mean(times_st), ls="--", color="C1")
            ax.set(xticks=x, xticklabels=participants, ylabel="completion time [s]",
                   title=f"{attention} attention (like Fig. {7 if attention == 'full' else 8})")
            ax.legend()
            fig.savefig(out / f"times_{attention}.png", dpi=110, bbox_inches="tight")
            plt.close(fig)
        if attention == "divided":
            scores_sl = [r.get("error_score", 0) for r in sl.values()]
            scores_st = [r.get("error_score", 0) for r in st.values()]
            if len(scores_sl) >= 2 and len(scores_st) >= 2:
                # Higher (less negative) is better: test that stop's scores are lower.
                p = float(mannwhitneyu(scores_st, scores_sl, alternative="less").pvalue)
                lines += ["", f"Divided attention error score: sliding {np.mean(scores_sl):.1f}, stop {np.mean(scores_st):.1f} "
                          f"(one-tailed MWW, stop worse: p = {p:.4g})"]
    # Section IV.B: (divided - full) per participant, sliding vs stop.
    diff = {}
    for condition in (SLIDING, STOP):
        full, divided = t.get(("full", condition), {}), t.get(("divided", condition), {})
        diff[condition] = [divided[p]["completion_time_s"] - full[p]["completion_time_s"]
                           for p in full if p in divided and full[p]["completion_time_s"] and divided[p]["completion_time_s"]]
    if len(diff[SLIDING]) >= 2 and len(diff[STOP]) >= 2:
        comparisons.append(compare("divided - full completion time [s]", diff[SLIDING], diff[STOP]))
    lines += ["", "## One-tailed Mann-Whitney-Wilcoxon tests (sliding < stop)", "",
              "| comparison | sliding mean | stop mean | reduction | p |", "|---|---|---|---|---|"]
    for c in comparisons:
        lines.append(f"| {c.label} | {np.mean(c.sliding):.1f} | {np.mean(c.stop):.1f} | {100 * c.reduction:.0f} % | {c.p_value:.4g} |")
    text = "\n".join(lines) + "\n"
    (out / "report.md").write_text(text)
    return text
