"""The campaign's summary: one object per robot x controller (``summarise``), the Markdown
report with histograms (``write_report``).

Breach: a true minimum separation below the critical distance (``approach_settings.CRITICAL_M``).
Its rate's 95 % upper bound is the one-sided Clopper-Pearson bound (``clopper_pearson_upper``:
the beta quantile; 0 of N gives 1 - 0.05^(1/N), about 3/N). A breach *with an escape*: the
offline search (``escape.escape_exists``) found a motion keeping the critical distance from
``LOOKBACK_S`` before the closest moment; *after detection*: also from the moment the controller
first saw the person without a break up to the closest moment (the rest needed the arm to move
before anyone was seen: the sensors' share, not the controller's); *after the approach began*:
also from the start of the person's final approach (``escape.approach_onset_s``, from the truth;
the rest needed the arm to move before the person's motion announced it: prediction's share, out
of reach of a controller that reacts to what it sees). *People with a posture
recovery*: whose task stalled at joint limits and moved home (``control.recovery``). *People over
the acceleration limit*: whose run commanded a joint acceleration above the robot's limit at
least once (``max_joint_acceleration_ratio`` above ``OVER_LIMIT``): steps where safety won over
smoothness, a motion a real arm would not follow (libfranka's and KUKA's controllers stop the
robot on it), so the distances of those runs are of an arm that did what no real one could.
*SSM*: ISO/TS 15066's speed and separation monitoring on every controller of the run (``off``,
``scaling``, ``stop``; results from before it was recorded ran without it). The *plant* says how
the arm followed the commands: ``ideal`` (exactly, every step) or ``rate-limited`` (through the
robot's rate limiter, ``arm.rate_limiter``, closed loop: the filter saw the state the arm
reached); *people rate-limited*: whose run had at least one step the
limiter changed (with it, the acceleration ratios are of the motion the arm made, at most 1; the
limiter also changes commands within the limits: its speed-dependent acceleration bound, linear
in the speed left, is stricter than the jerk-limited ramp the filter plans with); *people with
safety over smoothness*: whose filter commanded beyond the motion limits at least once to keep a
limitation (the filter's own count, ``StepReport.safety_over_smoothness``); *people over the
hand's limits*: whose commanded hand path went above the robot's end-effector acceleration or jerk
limit (``max_ee_acceleration_ratio``, ``max_ee_jerk_ratio`` above ``OVER_LIMIT``; the rate limiter
bounds the joints, not the hand). Results from before a quantity was kept give ``None`` for it:
unknown, not 0.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

REPORT_KEYS = ("robot", "controller", "people", "breaches", "breach_rate_upper_95", "breaches_with_escape",
               "breaches_with_escape_after_detection", "breaches_with_escape_after_approach_onset",
               "median_true_min_distance_m", "p05_true_min_distance_m", "completion_rate", "median_time_lost_s",
               "max_joint_acceleration_ratio", "people_over_acceleration_limit", "people_with_posture_recovery",
               "plant", "people_rate_limited", "people_with_safety_over_smoothness", "max_ee_acceleration_ratio",
               "people_over_hand_limits", "ssm")
#: A run's largest joint acceleration ratio counts as over the limit above this (the filter plans
#: within ``MOTION_MARGIN`` of the limits; finite differences of a kept run give at most 1.0000).
OVER_LIMIT = 1.001


def clopper_pearson_upper(breaches: int, people: int, confidence: float = 0.95) -> float:
    """One-sided upper bound of a binomial rate with ``breaches`` of ``people`` at ``confidence``."""
    from scipy.stats import beta

    if people <= 0:
        return 1.0
    if breaches >= people:
        return 1.0
    return float(beta.ppf(confidence, breaches + 1, people - breaches))


def summarise(results: list[dict]) -> list[dict]:
    """``REPORT_KEYS`` per (robot, controller) over the per-person results."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in results:
        groups.setdefault((r["robot"], r["controller"]), []).append(r)
    out = []
    for (robot, controller), rows in sorted(groups.items()):
        true = np.array([r["true_min_distance_m"] for r in rows if r["true_min_distance_m"] is not None], float)
        breaches = sum(bool(r["breach"]) for r in rows)
        lost = np.array([r["time_lost_s"] for r in rows if r["time_lost_s"] is not None], float)
        hand = all(r.get("max_ee_acceleration_ratio") is not None and r.get("max_ee_jerk_ratio") is not None
                   for r in rows)
        out.append({
            "robot": robot, "controller": controller, "people": len(rows), "breaches": breaches,
            "breach_rate_upper_95": round(clopper_pearson_upper(breaches, len(rows)), 6),
            "breaches_with_escape": sum(r["escape_exists"] is True for r in rows),
            "breaches_with_escape_after_detection": sum(r.get("escape_after_detection") is True for r in rows),
            "breaches_with_escape_after_approach_onset": sum(r.get("escape_after_approach_onset") is True
                                                             for r in rows),
            "median_true_min_distance_m": round(float(np.median(true)), 4) if true.size else None,
            "p05_true_min_distance_m": round(float(np.percentile(true, 5)), 4) if true.size else None,
            "completion_rate": round(sum(bool(r["completed"]) for r in rows) / len(rows), 4),
            "median_time_lost_s": round(float(np.median(lost)), 4) if lost.size else None,
            "max_joint_acceleration_ratio": round(max(r["max_joint_acceleration_ratio"] for r in rows), 4),
            "people_over_acceleration_limit": sum(r["max_joint_acceleration_ratio"] > OVER_LIMIT for r in rows),
            "people_with_posture_recovery": sum(r.get("posture_recoveries", 0) > 0 for r in rows),
            "plant": "/".join(sorted({r.get("plant", "ideal") for r in rows})),
            "ssm": "/".join(sorted({r.get("ssm", "off") for r in rows})),
            "people_rate_limited": sum(r.get("rate_limited_steps", 0) > 0 for r in rows),
            "people_with_safety_over_smoothness": None if any("safety_over_smoothness_steps" not in r for r in rows)
            else sum(r["safety_over_smoothness_steps"] > 0 for r in rows),  # (None: results from before it was kept)
            "max_ee_acceleration_ratio": None if not hand else round(max(r["max_ee_acceleration_ratio"] for r in rows), 4),
            "people_over_hand_limits": None if not hand else sum(
                max(r["max_ee_acceleration_ratio"], r["max_ee_jerk_ratio"]) > OVER_LIMIT for r in rows),
        })
    return out


def write_report(results: list[dict], out_dir: Path, header: str = "") -> list[dict]:
    """``out_dir/report.json`` (``summarise``), ``out_dir/report.md`` and one histogram PNG per robot."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cobotsafety.experiments import approach_settings as settings

    out_dir.mkdir(parents=True, exist_ok=True)
    summary = summarise(results)
    (out_dir / "report.json").write_text(json.dumps(summary, indent=1) + "\n")
    lines = ["# Validation campaign", "", header, "",
             f"Critical distance {settings.CRITICAL_M:.3f} m (a breach: the true separation below it); "
             f"settings: {json.dumps(settings.as_dict())}.", "",
             "| robot | controller | people | breaches | breach rate ≤ (95 %) | with escape | of which after detection | "
             "of which after the approach began | "
             "median true min | p05 true min | completion | median time lost | max joint accel ratio | "
             "people over the accel limit | posture moves home | plant | SSM | people rate-limited | "
             "people with safety over smoothness | max hand accel ratio | people over the hand's limits |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    fmt = lambda v, unit="": "—" if v is None else f"{v}{unit}"  # noqa: E731
    for s in summary:
        lines.append(f"| {s['robot']} | {s['controller']} | {s['people']} | {s['breaches']} | "
                     f"{s['breach_rate_upper_95']:.4f} | {s['breaches_with_escape']} | "
                     f"{s['breaches_with_escape_after_detection']} | {s['breaches_with_escape_after_approach_onset']} | "
                     f"{fmt(s['median_true_min_distance_m'], ' m')} | {fmt(s['p05_true_min_distance_m'], ' m')} | "
                     f"{s['completion_rate']:.3f} | {fmt(s['median_time_lost_s'], ' s')} | "
                     f"{s['max_joint_acceleration_ratio']:.2f} | {s['people_over_acceleration_limit']} | "
                     f"{s['people_with_posture_recovery']} | {s['plant']} | {s['ssm']} | {s['people_rate_limited']} | "
                     f"{fmt(s['people_with_safety_over_smoothness'])} | {fmt(s['max_ee_acceleration_ratio'])} | "
                     f"{fmt(s['people_over_hand_limits'])} |")
    lines += ["", "Breaches by what the person did (kind / reach):", ""]
    by_kind: dict[tuple, list[int]] = {}
    for r in results:
        d = r["drawn"]
        key = (r["robot"], r["controller"], d["kind"] + ("/" + d.get("reach", "") if d["kind"] == "approach" else "")
               + (" +1" if "second" in d else ""))
        by_kind.setdefault(key, [0, 0])
        by_kind[key][0] += bool(r["breach"])
        by_kind[key][1] += 1
    lines += ["| robot | controller | person | breaches / people |", "|---|---|---|---|"]
    lines += [f"| {k[0]} | {k[1]} | {k[2]} | {v[0]} / {v[1]} |" for k, v in sorted(by_kind.items())]
    for robot in sorted({s["robot"] for s in summary}):
        fig, ax = plt.subplots(figsize=(7, 4))
        for s in summary:
            if s["robot"] != robot:
                continue
            values = [r["true_min_distance_m"] for r in results
                      if r["robot"] == robot and r["controller"] == s["controller"] and r["true_min_distance_m"] is not None]
            ax.hist(np.array(values) * 1000, bins=30, histtype="step", label=s["controller"])
        ax.axvline(settings.CRITICAL_M * 1000, color="r", ls="--", lw=0.8, label="critical distance")
        ax.set(xlabel="true minimum distance [mm]", ylabel="people", title=f"{robot}: true minimum distance per person")
        ax.legend(fontsize=8)
        png = out_dir / f"histogram_{robot}.png"
        fig.savefig(png, dpi=100, bbox_inches="tight")
        plt.close(fig)
        lines += ["", f"![{robot}]({png.name})"]
    (out_dir / "report.md").write_text("\n".join(lines) + "\n")
    return summary
