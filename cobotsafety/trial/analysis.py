"""The trial report (paper 1, IV.A-B): Markdown tables and the figures a journal prints.

``analyze(directory, out)`` loads the log (problems reported with file and line), scores every
record with ``cobotsafety.trial.scoring`` (so browser logs are scored by the same rule), runs
``cobotsafety.trial.comparisons.compare_all`` (the analysis ``plan.json`` declared) and writes
``report.md`` with: the declaration, a descriptive table (mean ± SD, median, % change), the
primary and secondary tests (statistic, p with its method and tail, Holm-adjusted p, effect
size, bootstrap CI), the mixed model, the order checks ("not detected" with their power), the
skipped trials with their reasons, and for simulated logs what the model did. Figures, each as
300-dpi PNG, SVG and PDF (``figures.py``): completion time per participant in each mode,
error scores, and the attention interaction on a log axis.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cobotsafety.trial.log_store import load
from cobotsafety.trial.plan import ANALYSIS, read_plan
from cobotsafety.trial.comparisons import compare_all
from cobotsafety.trial.statistics import SLIDING, STOP, Result, describe

PAPER_SAVING = {"full": 0.20, "divided": 0.32}


def results_for(directory: Path) -> tuple[list[Result], list[dict], list[str]]:
    """(results, records, problems) of the log in ``directory``."""
    loaded = load(Path(directory))
    return compare_all(loaded.records), loaded.records, loaded.problems


def _fmt(x, digits: int = 2) -> str:
    return "-" if x is None else f"{x + 0.0:.{digits}f}"


def _p(p) -> str:
    if p is None:
        return "-"
    return f"{p:.2g}" if p >= 1e-4 else f"{p:.1e}"


def _statistic(r: Result) -> str:
    if r.statistic is None:
        return "-"
    name = {"mann-whitney": "U", "wilcoxon": "W", "linear mixed": "z"}
    label = next((v for k, v in name.items() if r.test.startswith(k)), "")
    return f"{label} = {r.statistic:.4g}"


def _rows(results: list[Result]) -> list[str]:
    lines = ["| comparison | test | n | sliding mean | stop mean | statistic | p (method, tail) | p Holm | effect size "
             "| 95 % CI |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        ci = "-" if r.ci95 is None else f"[{r.ci95[0]:.3g}, {r.ci95[1]:.3g}]"
        p = "not tested*" if r.p is None else f"{_p(r.p)} ({r.p_method}, {r.tail})"
        lines.append(f"| {r.comparison} | {r.test} | {r.n} | {_fmt(r.sliding_mean)} | {_fmt(r.stop_mean)} | "
                     f"{_statistic(r)} | {p} | {_p(r.p_holm)} | {_fmt(r.effect_size)} | {ci} |")
    return lines


def _declaration(directory: Path) -> list[str]:
    plan = read_plan(directory)
    if plan is None:
        lines = ["No `plan.json` in the log folder: the analysis below is the package's default declaration "
                 "(`cobotsafety.trial.plan.ANALYSIS`), not one written before the data."]
        analysis = ANALYSIS
    else:
        lines = [f"Declared in `plan.json`, written {plan.get('written_utc', '?')} before the first trial "
                 f"(seed {plan.get('seed')})."]
        analysis = plan.get("analysis", ANALYSIS)
    primary, secondary = analysis["primary"], analysis["secondary"]
    lines += ["", f"- **Primary outcome**: {primary['outcome']}; tests: {'; '.join(primary['tests'])}; "
                  f"tail: {primary['tail']}; alpha {primary['alpha']}; {primary['correction']}.",
              f"- **Secondary**: {'; '.join(secondary['outcomes'])}. {secondary['correction']}. Supporting: "
              f"{secondary['supporting']}.",
              f"- **Checks**: {analysis['checks']['order']}.",
              f"- **p-values**: {analysis['p_values']}."]
    return lines


def _order_lines(results: list[Result]) -> list[str]:
    lines = []
    for r in results:
        if r.role != "check":
            continue
        x = r.extra
        if r.p is None:
            lines.append(f"- {r.comparison}: not tested ({r.reason}).")
            continue
        power = f", power {100 * x['power']:.0f} % for a {x['power_for']}" if "power" in x else ""
        lines.append(f"- {r.comparison}: **{x['verdict']}** (U = {r.statistic:g}, p = {_p(r.p)} {r.p_method}, "
                     f"two-sided{power}); mean advantage {_fmt(x['sliding_first_mean'])} s with sliding first "
                     f"(n = {x['n_sliding_first']}) vs {_fmt(x['stop_first_mean'])} s with stop first "
                     f"(n = {x['n_stop_first']}).")
    return lines


def _model_lines(records: list[dict]) -> list[str]:
    """For simulated logs: what the participant model did (stops by trial position, savings)."""
    sim = [r for r in records if "model" in r and not r.get("skipped")]
    if not sim:
        return []
    lines = ["", "## What the simulated participants did", "",
             "Time the robot did not follow the drag (share of the trial) and stops noticed, stop condition, by "
             "the trial's position in the participant's session (the model learns the limits: detours shrink "
             "with practice):", "", "| position | stop trials | still share | stops noticed | known stops |",
             "|---|---|---|---|---|"]
    for order in (1, 2, 3, 4):
        cell = [r for r in sim if r["condition"] == STOP and r["order"] == order and r.get("completion_time_s")]
        if cell:
            share = np.mean([r["model"]["still_s"] / r["completion_time_s"] for r in cell])
            lines.append(f"| {order} | {len(cell)} | {100 * share:.0f} % | "
                         f"{np.mean([r['model']['stops_noticed'] for r in cell]):.1f} | "
                         f"{np.mean([r['model']['known_stops'] for r in cell]):.1f} |")
    lines += ["", "Time saving of sliding (1 - mean sliding time / mean stop time) against paper 1's:", ""]
    for attention in ("full", "divided"):
        sl = [r["completion_time_s"] for r in sim if r["attention"] == attention and r["condition"] == SLIDING
              and r.get("completion_time_s")]
        st = [r["completion_time_s"] for r in sim if r["attention"] == attention and r["condition"] == STOP
              and r.get("completion_time_s")]
        if sl and st:
            lines.append(f"- {attention} attention: {100 * (1 - np.mean(sl) / np.mean(st)):.0f} % "
                         f"(paper 1: {100 * PAPER_SAVING[attention]:.0f} %)")
    return lines


def report_text(directory: Path, results: list[Result], records: list[dict], problems: list[str]) -> str:
    participants = sorted({r["participant"] for r in records})
    skipped = [r for r in records if r.get("skipped")]
    lines = ["# Trial report", "",
             f"Log: `{directory}`: {len(records)} trials ({len(skipped)} skipped), {len(participants)} participants.",
             "Scoring: missed colour -2, wrong colour -1, touched triangle -3; colour words shown before the start "
             "or within the 2 s answer window before the end are not scored (`cobotsafety.trial.scoring`).",
             "", "## Analysis plan", ""] + _declaration(directory)
    if problems:
        lines += ["", "## Problems in the logs (the rest was analysed)", ""] + [f"- {p}" for p in problems]
    if skipped:
        lines += ["", "## Skipped trials (left out of every test)", ""] + [
            f"- {r['participant']} #{r['order']} {r['attention']} / {r['condition']}: {r.get('skip_reason', '?')} "
            f"(reached {r.get('targets_reached', '?')} targets)" for r in skipped]
    lines += ["", "## Descriptive statistics", "",
              "| attention | outcome | sliding: mean ± SD (median, n) | stop: mean ± SD (median, n) | % change |",
              "|---|---|---|---|---|"]
    for d in describe(records):
        sl, st, change = d.cells()
        lines.append(f"| {d.attention} | {d.label} | {sl} | {st} | {change} |")
    lines += ["", "## Tests", "",
              "Tails are in the direction sliding - stop (`less`: sliding lower). U is scipy's Mann-Whitney "
              "statistic of the sliding sample, W scipy's signed-rank statistic of sliding - stop (the rank sum "
              "of the positive differences), z the mixed model's Wald statistic. Effect size: rank-biserial "
              "correlation, positive = favours sliding (mixed model: the coefficient, negative = favours "
              "sliding). 95 % CI: bootstrap (BCa) of the mean difference sliding - stop (paired differences for "
              "Wilcoxon, group means for Mann-Whitney); mixed model: Wald interval of the coefficient. "
              "p Holm: Holm-adjusted within the family (primary or secondary) and test.", "",
              "### Primary", ""] + _rows([r for r in results if r.role == "primary"])
    lines += ["", "### Secondary", ""] + _rows([r for r in results if r.role == "secondary"])
    lines += ["", "### Supporting: mixed model", ""] + _rows([r for r in results if r.role == "supporting"])
    mixed = next((r for r in results if r.role == "supporting" and r.p is not None), None)
    if mixed is not None:
        lines += ["", f"The interaction coefficient {mixed.effect_size:+.3f} means sliding's saving is "
                      f"{abs(mixed.extra['percent']):.0f} % {'larger' if mixed.effect_size < 0 else 'smaller'} "
                      f"in divided than in full attention (log scale)."]
    lines += ["", "### Order checks", ""] + _order_lines(results)
    notes = [f"- {r.comparison}, {r.test}: {r.reason}." for r in results if r.reason]
    if notes:
        lines += ["", "Tests with too few data or a caveat (*: not run, no p-value):", ""] + notes
    lines += _model_lines(records)
    lines += ["", "Figures: `times_full`, `times_divided`, `error_scores`, `interaction` (each .png at 300 dpi, "
                  ".svg, .pdf)."]
    return "\n".join(lines) + "\n"


def analyze(directory: Path, out: Path | None = None) -> str:
    """Write ``report.md`` and the figures to ``out`` (default ``directory/report``); return the text."""
    return write_report(directory, out)[0]


def write_report(directory: Path, out: Path | None = None) -> tuple[str, list[Result]]:
    """``analyze``, also returning the results (for ``cobotsafety analyze --json``)."""
    from cobotsafety.trial.figures import write_figures  # noqa: PLC0415

    directory = Path(directory)
    out = Path(out) if out is not None else directory / "report"
    out.mkdir(parents=True, exist_ok=True)
    results, records, problems = results_for(directory)
    text = report_text(directory, results, records, problems)
    if any(not r.get("skipped") for r in records):
        write_figures(out, records)
    (out / "report.md").write_text(text)
    return text, results
