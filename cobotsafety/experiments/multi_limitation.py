"""Paper 1, experiment 3 (Fig. 9): autonomous motion among connected and separated zones.

The end-effector starts at (-0.2, 0.03) m and is driven toward the target by a saturated
proportional command ``v = gain (target - p)``; the method under test filters it. A run ends
when the target is reached (within ``tolerance_m``), when the robot has stalled (speed below
``stall_speed_m_s`` for ``stall_time_s``), or at ``timeout_s``.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

METHODS = ("anticipative", "reactive", "stop")
SCENARIOS = ("a", "b")


@dataclass(frozen=True)
class DriveParams:
    gain_per_s: float = 2.0
    max_speed_m_s: float = 0.2
    dt_s: float = 0.002
    tolerance_m: float = 0.005
    stall_speed_m_s: float = 1e-3
    stall_time_s: float = 0.5
    timeout_s: float = 20.0


@dataclass(frozen=True)
class RunResult:
    scenario: str
    method: str
    reached: bool
    time_s: float | None
    min_clearance_m: float
    """Closest approach to any protection zone (negative = penetration) [m]."""
    clearance_per_zone_m: dict
    path_m: np.ndarray
    """Shape (k, 2), the end-effector path [m]."""

    def as_json(self) -> dict:
        return {
            "scenario": self.scenario,
            "method": self.method,
            "reached": self.reached,
            "time_s": self.time_s,
            "min_clearance_m": self.min_clearance_m,
        }


def run_scenario(scenario: str, method: str, params: DriveParams = DriveParams()) -> RunResult:
    from cobotsafety.planar.scenarios import FIG9_TARGET_M, fig9_scene
    from cobotsafety.planar.teleop import PlanarTeleop

    scene = fig9_scene(scenario)
    zones = [lim for lim in scene.limitations if lim.name.startswith("F")]
    robot = PlanarTeleop(scene)
    target = np.array(FIG9_TARGET_M)
    clearance = {zone.name: np.inf for zone in zones}
    path = [robot.p_base_ee_m[:2].copy()]
    still_s, t = 0.0, 0.0
    reached = False
    while t < params.timeout_s:
        offset = target - robot.p_base_ee_m[:2]
        if np.linalg.norm(offset) <= params.tolerance_m:
            reached = True
            break
        command = params.gain_per_s * offset
        speed = np.linalg.norm(command)
        if speed > params.max_speed_m_s:
            command *= params.max_speed_m_s / speed
        report = robot.step(command, params.dt_s, method)
        t += params.dt_s
        kin = robot.kinematics
        for zone in zones:
            clearance[zone.name] = min(clearance[zone.name], zone.distance(kin))
        path.append(report.p_base_ee_m[:2].copy())
        still_s = still_s + params.dt_s if np.linalg.norm(report.v_executed_m_s) < params.stall_speed_m_s else 0.0
        if still_s >= params.stall_time_s:
            break
    return RunResult(scenario, method, reached, round(t, 3) if reached else None,
                     float(min(clearance.values())), clearance, np.array(path))


def plot(results: list[RunResult], out_dir: Path) -> list[Path]:
    """One PNG per scenario: zones, limits and the end-effector paths (like Fig. 9)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    from cobotsafety.planar.limitations import PolygonZone, RectangleZone
    from cobotsafety.planar.scenarios import BASE_RADIUS_M, FIG9_START_M, FIG9_TARGET_M, fig9_scene

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    styles = {"anticipative": ("tab:red", "--"), "reactive": ("tab:blue", "-"), "stop": ("k", ":")}
    for scenario in SCENARIOS:
        fig, ax = plt.subplots(figsize=(5, 4.5))
        for zone in fig9_scene(scenario).limitations:
            if isinstance(zone, RectangleZone):
                ax.add_patch(Polygon(zone.vertices(), color="0.6"))
            elif isinstance(zone, PolygonZone):
                ax.add_patch(Polygon(zone.vertices_m, color="0.6"))
        ax.add_patch(Circle((0, 0), BASE_RADIUS_M, fill=False, ls="-.", color="0.4"))
        for result in results:
            if result.scenario == scenario:
                color, ls = styles[result.method]
                label = f"{result.method} ({'reached' if result.reached else 'stopped'})"
                ax.plot(result.path_m[:, 0], result.path_m[:, 1], ls=ls, color=color, label=label)
        ax.plot(*FIG9_START_M, "ko")
        ax.plot(*FIG9_TARGET_M, "g*", ms=12)
        ax.set(xlim=(-0.55, 0.05), ylim=(-0.05, 0.4), aspect="equal", xlabel="x [m]", ylabel="y [m]",
               title=f"Fig. 9 scenario {scenario}")
        ax.legend(loc="lower left", fontsize=8)
        path = out_dir / f"fig9_{scenario}.png"
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print a JSON list of results")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="write the Fig. 9-like PNGs there (default: out/multi_limitation)")


def run(args: argparse.Namespace) -> int:
    results = [run_scenario(scenario, method) for scenario in SCENARIOS for method in METHODS]
    written = plot(results, args.out or Path("out/multi_limitation"))
    if args.json:
        print(json.dumps([r.as_json() for r in results]))
    else:
        print(f"{'scenario':8} {'method':13} {'reached':7} {'time_s':>7} {'min_clearance_m':>16}")
        for r in results:
            time_s = f"{r.time_s:.2f}" if r.time_s is not None else "-"
            print(f"{r.scenario:8} {r.method:13} {str(r.reached):7} {time_s:>7} {r.min_clearance_m:16.5f}")
        print("plots: " + ", ".join(str(p) for p in written))
    return 0
