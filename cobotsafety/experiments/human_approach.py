"""Paper 2, experiment 2, headless: a human walks up to the robot during a pick-and-place task.

The bundled recording (``assets/recordings/approach.jsonl.gz``) is replayed through the whole
sensor pipeline (laser legs -> torso, IMUs -> arms, causal) while the panda follows
``pick_and_place()`` through an anti-windup PI on the error to the moving target (eqs. 14-15).
Reported per controller: minimum human-robot capsule distance, peak end-effector speed, task
completion time, and time spent stopped (end-effector slower than 1 mm/s before the task is
done). PNGs like the paper's Figs. 11/14 (distance, end-effector position and speed over time)
and Fig. 12 (end-effector and torso paths from above).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

STOPPED_SPEED_M_S = 1e-3


@dataclass
class ApproachRun:
    controller: str
    ssm: bool
    min_distance_m: float
    peak_ee_speed_m_s: float
    completion_time_s: float | None
    stopped_time_s: float
    t_s: np.ndarray
    distance_m: np.ndarray
    p_ee_m: np.ndarray
    speed_m_s: np.ndarray
    torso_xy_m: np.ndarray

    def as_json(self) -> dict:
        return {
            "controller": self.controller + ("+ssm" if self.ssm else ""),
            "min_distance_m": round(self.min_distance_m, 4),
            "peak_ee_speed_m_s": round(self.peak_ee_speed_m_s, 4),
            "completion_time_s": None if self.completion_time_s is None else round(self.completion_time_s, 3),
            "stopped_time_s": round(self.stopped_time_s, 3),
        }


def run_approach(controller: str, ssm: bool = False, dt_s: float = 0.004, timeout_s: float = 60.0,
                 recording: Path | None = None) -> ApproachRun:
    from importlib import resources

    from cobotsafety.control.controllers import HumanAwareArm
    from cobotsafety.control.nominal_path import pick_and_place
    from cobotsafety.control.pi import AntiWindupPI
    from cobotsafety.human.replay import Replay

    path_file = recording or resources.files("cobotsafety.assets").joinpath("recordings", "approach.jsonl.gz")
    replay = Replay.from_file(path_file)
    arm = HumanAwareArm("panda")
    path = pick_and_place()
    pi = AntiWindupPI(kp_per_s=3.0, ki_per_s2=1.0, limit=0.5)
    t = 0.0
    log_t, log_d, log_p, log_v, log_torso = [], [], [], [], []
    completion = None
    stopped_time = 0.0
    while t < timeout_s:
        replay_t = replay.start_s + t
        if replay_t <= replay.start_s + replay.duration_s:
            capsules = replay.capsules_at(replay_t)
            if capsules.present:
                arm.set_human(t, capsules.p0_b_m, capsules.p1_b_m, capsules.radius_m, capsules.names)
                log_torso.append(0.5 * (capsules.p0_b_m[0, :2] + capsules.p1_b_m[0, :2]))
            else:
                arm.clear_human()
        else:
            arm.clear_human()  # the recording is over: the human has left
        p_ee = arm.state.p_world_ee
        target = path.advance(p_ee, dt_s)
        v_att = pi.update(target - p_ee, dt_s)
        result = arm.step(v_att, dt_s, controller, ssm)
        t += dt_s
        speed = float(np.linalg.norm(result.report.v_executed_m_s))
        log_t.append(t)
        log_d.append(result.min_distance_m)
        log_p.append(result.report.p_base_ee_m)
        log_v.append(speed)
        if speed < STOPPED_SPEED_M_S and t > 0.5:
            stopped_time += dt_s
        if path.finished and np.linalg.norm(arm.state.p_world_ee - path.point(path.length_m)) < 0.01:
            completion = t
            break
    distance = np.array(log_d)
    return ApproachRun(controller, ssm, float(np.min(distance)), float(np.max(log_v)), completion, stopped_time,
                       np.array(log_t), distance, np.array(log_p), np.array(log_v),
                       np.array(log_torso).reshape(-1, 2))


def plot(runs: list[ApproachRun], out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for run in runs:
        label = run.as_json()["controller"]
        fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
        d = np.where(np.isfinite(run.distance_m), run.distance_m, np.nan)
        axes[0].plot(run.t_s, 1000 * d)
        axes[0].set_ylabel("min distance [mm]")
        for i, axis in enumerate("xyz"):
            axes[1].plot(run.t_s, 1000 * run.p_ee_m[:, i], label=axis)
        axes[1].set_ylabel("EE position [mm]")
        axes[1].legend(loc="upper right", fontsize=8)
        axes[2].plot(run.t_s, 1000 * run.speed_m_s)
        axes[2].set_ylabel("EE speed [mm/s]")
        axes[2].set_xlabel("t [s]")
        fig.suptitle(f"human approach — {label} (like Figs. 11, 14)")
        path = out_dir / f"human_approach_{label.replace('+', '_')}_time.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
        fig, ax = plt.subplots(figsize=(5, 5))
        ax.plot(run.p_ee_m[:, 0], run.p_ee_m[:, 1], label="end-effector")
        if run.torso_xy_m.size:
            ax.plot(run.torso_xy_m[:, 0], run.torso_xy_m[:, 1], label="human torso")
        ax.plot(0, 0, "ks", label="robot base")
        ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title=f"paths from above — {label} (like Fig. 12)")
        ax.legend(fontsize=8)
        path = out_dir / f"human_approach_{label.replace('+', '_')}_paths.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--controller", choices=["anticipative", "reactive", "stop"], action="append",
                        help="controller(s) to run (default: all three)")
    parser.add_argument("--ssm", action="store_true", help="add the ISO/TS 15066 speed-and-separation layer")
    parser.add_argument("--json", action="store_true", help="print a JSON list of result objects")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="write the PNG plots there (default: out/human_approach)")
    parser.add_argument("--dt", type=float, default=0.004, help="control period [s] (default 0.004)")


def run(args: argparse.Namespace) -> int:
    runs = [run_approach(c, args.ssm, args.dt) for c in (args.controller or ["anticipative", "reactive", "stop"])]
    written = plot(runs, args.out or Path("out/human_approach"))
    if args.json:
        print(json.dumps([r.as_json() for r in runs]))
    else:
        for r in runs:
            print(json.dumps(r.as_json()))
        print("plots: " + ", ".join(str(p) for p in written))
    return 0
