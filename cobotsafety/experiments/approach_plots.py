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
        log = run.log
        t = np.array(log.t_s)
        p_ee = np.array(log.p_ee_m).reshape(-1, 3)
        speed = np.linalg.norm(np.array(log.v_ee_m_s).reshape(-1, 3), axis=1)
        fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
        for values, name in ((log.seen_m, "seen by the controller"), (log.estimate_m, "to the estimated human (5 capsules)"),
                             (log.one_capsule_m, "to the one-capsule fallback"), (log.true_m, "to the true human")):
            values = np.asarray(values, float)
            if np.isfinite(values).any():
                axes[0].plot(t, 1000 * np.where(np.isfinite(values), values, np.nan), label=name)
        axes[0].axhline(1000 * run.critical_m, color="r", lw=0.8, ls="--", label="critical distance")
        if run.scenario in PAPER_RESULTS:
            axes[0].axhline(1000 * PAPER_RESULTS[run.scenario][0], color="k", lw=0.8, ls=":", label="paper's minimum")
        axes[0].set_ylabel("min distance [mm]")
        axes[0].legend(loc="upper right", fontsize=7)
        for i, axis in enumerate("xyz"):
            axes[1].plot(t, 1000 * p_ee[:, i], label=axis)
        axes[1].set_ylabel("EE position [mm]")
        axes[1].legend(loc="upper right", fontsize=8)
        axes[2].plot(t, 1000 * speed)
        if run.scenario in PAPER_RESULTS:
            axes[2].axhline(1000 * PAPER_RESULTS[run.scenario][1], color="k", lw=0.8, ls=":", label="paper's peak")
            axes[2].legend(loc="upper right", fontsize=7)
        axes[2].set_ylabel("EE speed [mm/s]")
        axes[2].set_xlabel("t [s]")
        ssm = "" if run.ssm == "off" else f" + SSM {run.ssm}"
        fig.suptitle(f"{run.recording}, {run.robot}, {run.controller}{ssm} (like Figs. 11, 14)")
        path = out_dir / f"human_approach_{run.label}_time.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
        fig, ax = plt.subplots(figsize=(5, 5))
        ax.plot(p_ee[:, 0], p_ee[:, 1], label="end-effector")
        torso = np.array(log.torso_xy_m).reshape(-1, 2)
        if torso.size:
            ax.plot(torso[:, 0], torso[:, 1], ".", ms=1, label="human torso (estimated)")
        ax.plot(0, 0, "ks", label="robot base")
        ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title=f"paths from above, {run.label} (like Fig. 12)")
        ax.legend(fontsize=7)
        path = out_dir / f"human_approach_{run.label}_paths.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written
