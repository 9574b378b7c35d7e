"""The trial report's figures, each written as a 300-dpi PNG, an SVG and a PDF.

* ``times_full``, ``times_divided``: completion time per participant, stop and sliding joined
  by one line per participant (participants spread a little sideways so equal values do not
  hide each other), group means with bootstrap 95 % intervals; the axis starts at 0 s.
* ``error_scores``: the error score per participant in both modes, drawn the same way, with
  the equal scores spread sideways (jitter) so every participant stays visible.
* ``interaction``: the attention interaction: completion time (log axis) in full and divided
  attention, one line per condition through the geometric means with 95 % intervals, every
  participant's two trials of a condition as a faint line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cobotsafety.trial.statistics import SLIDING, STOP, by_participant, completion, score

FORMATS = ("png", "svg", "pdf")
DPI = 300
COLOURS = {STOP: "C1", SLIDING: "C0"}
NAMES = {STOP: "stop", SLIDING: "sliding"}


def _save(fig, out: Path, stem: str) -> list[Path]:
    paths = []
    for fmt in FORMATS:
        path = out / f"{stem}.{fmt}"
        fig.savefig(path, dpi=DPI, bbox_inches="tight")
        paths.append(path)
    return paths


def _spread(count: int, width: float = 0.12, seed: int = 0) -> np.ndarray:
    """Small sideways offsets, one per participant (seeded: the same figure every time)."""
    return np.random.default_rng(seed).uniform(-width, width, count)


def _mean_ci(values: np.ndarray) -> tuple[float, list | None]:
    from scipy.stats import bootstrap  # noqa: PLC0415

    mean = float(values.mean())
    if len(values) >= 2 and np.ptp(values) > 0:
        ci = bootstrap((values,), np.mean, n_resamples=9999, random_state=np.random.default_rng(0)).confidence_interval
        return mean, [[mean - ci.low], [ci.high - mean]]
    return mean, None


def paired_panel(ax, t: dict, attention: str, value, unit_label: str, title: str,
                 ylim: tuple[float, float] | None = None) -> None:
    sl, st = t.get((attention, SLIDING), {}), t.get((attention, STOP), {})
    ids = sorted(p for p in set(sl) & set(st) if value(sl[p]) is not None and value(st[p]) is not None)
    offsets = _spread(len(ids))
    for p, dx in zip(ids, offsets):
        ax.plot((0.0 + dx, 1.0 + dx), (value(st[p]), value(sl[p])), color="0.65", lw=0.8, marker="o", ms=3.5,
                mfc="white", zorder=1)
    for x, condition, marker in ((0.0, STOP, "o"), (1.0, SLIDING, "X")):
        group = sl if condition == SLIDING else st
        vals = np.array([v for r in group.values() if (v := value(r)) is not None], float)
        if len(vals) == 0:
            continue
        mean, err = _mean_ci(vals)
        ax.errorbar([x - 0.3 if x == 0.0 else x + 0.3], [mean], yerr=err, fmt=marker, ms=10, mew=2, capsize=6,
                    color=COLOURS[condition], zorder=3, label=f"{NAMES[condition]} mean (95 % CI), n = {len(vals)}")
    ax.set_xticks((0.0, 1.0), ["stop", "sliding"])
    ax.set_xlim(-0.55, 1.55)
    ax.set_xlabel("condition (grey lines join one participant's two trials)")
    ax.set_ylabel(unit_label)
    ax.set_title(title, fontsize=10)
    ax.set_ylim(ylim if ylim is not None else (0.0, ax.get_ylim()[1]))
    ax.legend(fontsize=8, loc="best")


def interaction_panel(ax, t: dict) -> None:
    from scipy.stats import bootstrap  # noqa: PLC0415

    xs = np.array([0.0, 1.0])
    for condition, shift in ((STOP, -0.04), (SLIDING, 0.04)):
        full, divided = t.get(("full", condition), {}), t.get(("divided", condition), {})
        ids = sorted(p for p in set(full) & set(divided) if completion(full[p]) and completion(divided[p]))
        if not ids:
            continue
        logs = np.log(np.array([[completion(full[p]), completion(divided[p])] for p in ids]))
        for row, dx in zip(logs, _spread(len(ids), 0.05, seed=1 if condition == SLIDING else 2)):
            ax.plot(xs + shift + dx, np.exp(row), color=COLOURS[condition], alpha=0.25, lw=0.8, zorder=1)
        means, errs = [], []
        for k in range(2):
            m = float(logs[:, k].mean())
            if len(ids) >= 2 and np.ptp(logs[:, k]) > 0:
                ci = bootstrap((logs[:, k],), np.mean, n_resamples=9999,
                               random_state=np.random.default_rng(0)).confidence_interval
                errs.append((np.exp(m) - np.exp(ci.low), np.exp(ci.high) - np.exp(m)))
            else:
                errs.append((0.0, 0.0))
            means.append(np.exp(m))
        ax.errorbar(xs + shift, means, yerr=np.array(errs).T, color=COLOURS[condition], marker="o", ms=7, lw=2,
                    capsize=5, zorder=3, label=f"{NAMES[condition]}: geometric mean (95 % CI), n = {len(ids)}")
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter  # noqa: PLC0415

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 1.5, 2.0, 3.0, 5.0, 7.0)))
    ax.yaxis.set_major_formatter(ScalarFormatter())
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks(xs, ["full attention", "divided attention"])
    ax.set_xlim(-0.4, 1.4)
    ax.set_ylabel("completion time [s] (log axis)")
    ax.set_xlabel("attention mode (faint lines: one participant)")
    ax.set_title("Attention x condition on completion time (log scale):\n"
                 "non-parallel lines = the interaction the mixed model tests", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")


def write_figures(out: Path, records: list[dict]) -> list[Path]:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    t = by_participant(records)
    written = []
    for attention in ("full", "divided"):
        fig, ax = plt.subplots(figsize=(5.5, 4.2))
        paired_panel(ax, t, attention, completion, "completion time [s] (axis from 0)",
                     f"Completion time per participant, {attention} attention: stop vs sliding")
        written += _save(fig, out, f"times_{attention}")
        plt.close(fig)
    scores = [score(r) for r in records if not r.get("skipped")]
    lowest = min(scores) if scores else 0.0
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, attention in zip(axes, ("full", "divided")):
        paired_panel(ax, t, attention, score, "error score [points] (0 = no error)",
                     f"Error score per participant, {attention} attention: stop vs sliding",
                     ylim=(min(lowest, 0.0) - 1.0, 0.5))
    written += _save(fig, out, "error_scores")
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    interaction_panel(ax, t)
    written += _save(fig, out, "interaction")
    plt.close(fig)
    return written
