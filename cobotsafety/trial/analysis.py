"""The trial report (paper 1, IV.A-B): Markdown tables and the figures a paper would print.

``analyze(directory, out)`` loads the log (problems reported with file and line), scores every
record with ``cobotsafety.trial.scoring`` (so browser logs are scored by the same rule), runs
``cobotsafety.trial.statistics.compare_all`` and writes ``report.md`` with:

* ``times_full.png``, ``times_divided.png`` (like Figs. 7 and 8): completion time per
  participant, one line per participant joining stop and sliding, group means with bootstrap
  95 % intervals; the y-axis starts at 0 s;
* ``error_scores.png``: the error score per participant in both attention modes, drawn the
  same way; the axis runs from the lowest score to 0 points.

A comparison whose test cannot run is listed with the reason instead of a number.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cobotsafety.trial.log_store import load
from cobotsafety.trial.statistics import SLIDING, STOP, Result, by_participant, compare_all, completion, score


def results_for(directory: Path) -> tuple[list[Result], list[dict], list[str]]:
    """(results, records, problems) of the log in ``directory``."""
    loaded = load(Path(directory))
    return compare_all(loaded.records), loaded.records, loaded.problems


def _fmt(x, digits: int = 2) -> str:
    return "-" if x is None else f"{x + 0.0:.{digits}f}"


def _p(p) -> str:
    return "-" if p is None else f"{p:.2g}"


def report_text(directory: Path, results: list[Result], records: list[dict], problems: list[str]) -> str:
    participants = sorted({r["participant"] for r in records})
    lines = ["# Trial report", "",
             f"Log: `{directory}`: {len(records)} trials, {len(participants)} participants.",
             "Scoring: missed colour -2, wrong colour -1, touched triangle -3; colour words shown before the start "
             "or within the 2 s answer window before the end are not scored (`cobotsafety.trial.scoring`)."]
    if problems:
        lines += ["", "## Problems in the logs (the rest was analysed)", ""] + [f"- {p}" for p in problems]
    lines += ["", "## Tests", "",
              "One-tailed tests that sliding (`anticipative`) beats `stop`: the paper's Mann-Whitney-Wilcoxon "
              "(independent groups) and the paired Wilcoxon signed-rank test (every participant did both). "
              "Effect size: rank-biserial correlation, positive = favours sliding. 95 % CI: bootstrap (BCa) of the "
              "mean difference sliding - stop (paired differences for Wilcoxon, group means for MWW). The order rows "
              "compare the advantage (stop - sliding time) of participants who did sliding first with those who "
              "did stop first (two-sided; a difference means learning or carry-over).", "",
              "| comparison | test | n | sliding mean | stop mean | p | effect size | 95 % CI |",
              "|---|---|---|---|---|---|---|---|"]
    notes = []
    for r in results:
        ci = "-" if r.ci95 is None else f"[{r.ci95[0]:.2f}, {r.ci95[1]:.2f}]"
        p = _p(r.p) if r.p is not None else "not tested*"
        means = ("-", "-") if r.comparison.startswith("order effect") else (_fmt(r.sliding_mean), _fmt(r.stop_mean))
        lines.append(f"| {r.comparison} | {r.test} | {r.n} | {means[0]} | {means[1]} | {p} | "
                     f"{_fmt(r.effect_size)} | {ci} |")
        if r.reason:
            notes.append(f"- {r.comparison}, {r.test}: {r.reason}.")
    if notes:
        lines += ["", "Tests with too few data (*: not run, no p-value):", ""] + notes
    return "\n".join(lines) + "\n"


def _paired_panel(ax, t: dict, attention: str, value, unit_label: str, title: str,
                  ylim: tuple[float, float] | None = None) -> None:
    from scipy.stats import bootstrap

    sl, st = t.get((attention, SLIDING), {}), t.get((attention, STOP), {})
    ids = sorted(p for p in set(sl) & set(st) if value(sl[p]) is not None and value(st[p]) is not None)
    xs = (0.0, 1.0)
    for p in ids:
        ax.plot(xs, (value(st[p]), value(sl[p])), color="0.6", lw=0.8, marker=".", zorder=1)
    for x, group, marker, name in ((0.0, st, "o", "stop"), (1.0, sl, "x", "sliding")):
        vals = np.array([v for r in group.values() if (v := value(r)) is not None], float)
        if len(vals) == 0:
            continue
        mean = float(vals.mean())
        if len(vals) >= 2 and np.ptp(vals) > 0:
            ci = bootstrap((vals,), np.mean, n_resamples=9999, random_state=np.random.default_rng(0)).confidence_interval
            err = [[mean - ci.low], [ci.high - mean]]
        else:
            err = None
        ax.errorbar([x], [mean], yerr=err, fmt=marker, ms=11, mew=2.5, capsize=6, color="C0" if x else "C1",
                    zorder=3, label=f"{name} mean (95 % CI), n = {len(vals)}")
    ax.set_xticks(xs, ["stop", "sliding"])
    ax.set_xlim(-0.4, 1.4)
    ax.set_xlabel("condition (lines join one participant's two trials)")
    ax.set_ylabel(unit_label)
    ax.set_title(title, fontsize=10)
    ax.set_ylim(ylim if ylim is not None else (0.0, ax.get_ylim()[1]))
    ax.legend(fontsize=8, loc="best")


def write_figures(out: Path, records: list[dict]) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = by_participant(records)
    written = []
    for attention, fig_no in (("full", 7), ("divided", 8)):
        fig, ax = plt.subplots(figsize=(5.5, 4.2))
        _paired_panel(ax, t, attention, completion, "completion time [s] (axis from 0)",
                      f"Completion time per participant, {attention} attention (like Fig. {fig_no})")
        path = out / f"times_{attention}.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    lowest = min(score(r) for r in records)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, attention in zip(axes, ("full", "divided")):
        _paired_panel(ax, t, attention, score, "error score [points] (0 = no error)",
                      f"Error score per participant, {attention} attention", ylim=(min(lowest, 0.0) - 1.0, 0.5))
    fig.savefig(out / "error_scores.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    written.append(out / "error_scores.png")
    return written


def analyze(directory: Path, out: Path | None = None) -> str:
    """Write ``report.md`` and the figures to ``out`` (default ``directory/report``); return the text."""
    return write_report(directory, out)[0]


def write_report(directory: Path, out: Path | None = None) -> tuple[str, list[Result]]:
    """``analyze``, also returning the results (for ``cobotsafety analyze --json``)."""
    directory = Path(directory)
    out = Path(out) if out is not None else directory / "report"
    out.mkdir(parents=True, exist_ok=True)
    results, records, problems = results_for(directory)
    text = report_text(directory, results, records, problems)
    if records:
        write_figures(out, records)
    (out / "report.md").write_text(text)
    return text, results
