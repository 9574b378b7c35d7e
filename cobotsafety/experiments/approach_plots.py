"""PNGs of a human-approach run like paper 2's Figs. 11 and 14 (minimum distance, end-effector
position and speed over time) and Fig. 12 (end-effector and torso paths from above)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot(runs, out_dir: Path) -> list[Path]:
    """One time plot and one path plot per ``ApproachRun``; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cobotsafety.paper_figures import PAPER_RESULTS

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for run in runs:
        fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
        for values, name in ((run.distance_m, "seen by the controller"), (run.plain_m, "to the human's own capsules")):
            axes[0].plot(run.t_s, 1000 * np.where(np.isfinite(values), values, np.nan), label=name)
        axes[0].axhline(1000 * run.critical_m, color="r", lw=0.8, ls="--", label="critical / protected distance")
        if run.scenario in PAPER_RESULTS:
            axes[0].axhline(1000 * PAPER_RESULTS[run.scenario][0], color="k", lw=0.8, ls=":", label="paper's minimum")
        axes[0].set_ylabel("min distance [mm]")
        axes[0].legend(loc="upper right", fontsize=7)
        for i, axis in enumerate("xyz"):
            axes[1].plot(run.t_s, 1000 * run.p_ee_m[:, i], label=axis)
        axes[1].set_ylabel("EE position [mm]")
        axes[1].legend(loc="upper right", fontsize=8)
        axes[2].plot(run.t_s, 1000 * run.speed_m_s)
        if run.scenario in PAPER_RESULTS:
            axes[2].axhline(1000 * PAPER_RESULTS[run.scenario][1], color="k", lw=0.8, ls=":", label="paper's peak")
            axes[2].legend(loc="upper right", fontsize=7)
        axes[2].set_ylabel("EE speed [mm/s]")
        axes[2].set_xlabel("t [s]")
        fig.suptitle(f"{run.scenario}, {run.robot}, {run.controller}{' + SSM' if run.ssm else ''} (like Figs. 11, 14)")
        path = out_dir / f"human_approach_{run.label}_time.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
        fig, ax = plt.subplots(figsize=(5, 5))
        ax.plot(run.p_ee_m[:, 0], run.p_ee_m[:, 1], label="end-effector")
        if run.torso_xy_m.size:
            ax.plot(run.torso_xy_m[:, 0], run.torso_xy_m[:, 1], ".", ms=1, label="human torso (estimated)")
        ax.plot(0, 0, "ks", label="robot base")
        ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title=f"paths from above, {run.label} (like Fig. 12)")
        ax.legend(fontsize=7)
        path = out_dir / f"human_approach_{run.label}_paths.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written
