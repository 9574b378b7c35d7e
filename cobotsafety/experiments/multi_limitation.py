"""Paper 1, experiment 3 (Fig. 9): autonomous motion among connected and separated zones.

The end-effector starts at (-0.2, 0.03) m and is driven toward the target (0.22, 0.18) m by a
saturated proportional command ``v = gain (target - p)``; the method under test filters it. The
straight drive meets joint 2's circle B and slides along it toward a wall of zones standing on
B (``planar.scenarios.fig9_wall``): in (a) the wall's triangle touches B, a V in which two
limitations bind at once; in (b) a 6 cm gap separates them. A run ends when the target is
reached (within ``tolerance_m``), when the robot has stalled (speed below ``stall_speed_m_s``
for ``stall_time_s``), or at ``timeout_s``. ``max_binding`` is the most limitations binding in
one step.

The reactive method depends on its tuning, so ``--sweep`` runs it over ``SWEEP_WIDTHS_M`` x
``SWEEP_STIFFNESS_PER_S`` in both scenarios. The figure and the JSON use ``figure_reactive()``:
the default stiffness (60 /s) with 3 cm zones, the widest zones with which the reactive method
passes the 6 cm gap of (b) at that stiffness (a wider zone is a wider safety margin, so this is
the fairest setting that still works); the 4 cm default stalls at the triangle as in the paper.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

METHODS = ("anticipative", "reactive", "stop")
SCENARIOS = ("a", "b")
SWEEP_WIDTHS_M = (0.01, 0.02, 0.025, 0.03, 0.04)
SWEEP_STIFFNESS_PER_S = (20.0, 60.0, 150.0)


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
    max_binding: int = 0
    """The most limitations binding in one step."""
    final_binding: tuple[str, ...] = ()

    def as_json(self) -> dict:
        return {
            "scenario": self.scenario,
            "method": self.method,
            "reached": self.reached,
            "time_s": self.time_s,
            "min_clearance_m": self.min_clearance_m,
            "max_binding": self.max_binding,
        }


def figure_reactive():
    """The reactive setting of the figure and the JSON (see the module docstring)."""
    from cobotsafety.planar.baselines import ReactiveParams

    return ReactiveParams(stiffness_per_s=60.0, zone_width_m=0.03)


def run_scenario(scenario: str, method: str, params: DriveParams = DriveParams(), reactive=None) -> RunResult:
    from cobotsafety.planar.planar_scenes import FIG9_TARGET_M, fig9_scene
    from cobotsafety.planar.planar_teleop import PlanarTeleop

    scene = fig9_scene(scenario, reactive=reactive or figure_reactive())
    zones = [lim for lim in scene.limitations if lim.name.startswith("F")]
    robot = PlanarTeleop(scene)
    target = np.array(FIG9_TARGET_M)
    clearance = {zone.name: np.inf for zone in zones}
    path = [robot.p_base_ee_m[:2].copy()]
    still_s, t = 0.0, 0.0
    reached = False
    max_binding, binding = 0, ()
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
        binding = tuple(sorted(set(report.binding)))
        max_binding = max(max_binding, len(binding))
        t += params.dt_s
        kin = robot.kinematics
        for zone in zones:
            clearance[zone.name] = min(clearance[zone.name], zone.distance(kin))
        path.append(report.p_base_ee_m[:2].copy())
        still_s = still_s + params.dt_s if np.linalg.norm(report.v_executed_m_s) < params.stall_speed_m_s else 0.0
        if still_s >= params.stall_time_s:
            break
    return RunResult(scenario, method, reached, round(t, 3) if reached else None,
                     float(min(clearance.values())), clearance, np.array(path), max_binding, binding)


def sweep(params: DriveParams = DriveParams()) -> list[dict]:
    """The reactive method over zone widths and stiffnesses, in both scenarios."""
    from cobotsafety.planar.baselines import ReactiveParams

    rows = []
    for width in SWEEP_WIDTHS_M:
        for stiffness in SWEEP_STIFFNESS_PER_S:
            reactive = ReactiveParams(stiffness_per_s=stiffness, zone_width_m=width)
            for scenario in SCENARIOS:
                r = run_scenario(scenario, "reactive", params, reactive)
                rows.append({"zone_width_m": width, "stiffness_per_s": stiffness, "scenario": scenario,
                             "reached": r.reached, "time_s": r.time_s, "min_clearance_m": round(r.min_clearance_m, 5),
                             "max_binding": r.max_binding})
    return rows


def plot(results: list[RunResult], out_dir: Path) -> list[Path]:
    """One PNG per scenario: zones, limits and the end-effector paths (like Fig. 9)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    from cobotsafety.planar.limitations import PolygonZone, RectangleZone
    from cobotsafety.planar.planar_scenes import FIG9_START_M, FIG9_TARGET_M, fig9_scene, joint_2_circle_radius_m

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    styles = {"anticipative": ("tab:red", "--"), "reactive": ("tab:blue", "-"), "stop": ("k", ":")}
    for scenario in SCENARIOS:
        fig, ax = plt.subplots(figsize=(5, 4.5))
        scene = fig9_scene(scenario)
        for zone in scene.limitations:
            if isinstance(zone, RectangleZone):
                ax.add_patch(Polygon(zone.vertices(), color="0.6"))
            elif isinstance(zone, PolygonZone):
                ax.add_patch(Polygon(zone.vertices_m, color="0.6"))
        ax.add_patch(Circle((0, 0), joint_2_circle_radius_m(scene.arm), fill=False, ls="-.", color="0.4",
                            label="B: joint 2 limit (circle)"))
        for result in results:
            if result.scenario == scenario:
                color, ls = styles[result.method]
                name = result.method
                if name == "reactive":
                    w = figure_reactive()
                    name += f" ({100 * w.zone_width_m:.1f} cm, {w.stiffness_per_s:.0f}/s)"
                label = f"{name}: {'reached' if result.reached else 'stopped'}, max {result.max_binding} binding"
                ax.plot(result.path_m[:, 0], result.path_m[:, 1], ls=ls, color=color, label=label)
        ax.plot(*FIG9_START_M, "ko", label="start")
        ax.plot(*FIG9_TARGET_M, "g*", ms=12, label="target")
        ax.set(xlim=(-0.3, 0.35), ylim=(-0.05, 0.5), aspect="equal", xlabel="x [m]", ylabel="y [m]",
               title=f"Fig. 9 ({scenario}): end-effector paths\n"
                     f"{'zones joined to circle B' if scenario == 'a' else '6 cm gap between circle B and the triangle'}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=7, ncol=2)
        path = out_dir / f"fig9_{scenario}.png"
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
    return written


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print a JSON list of results")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="write the Fig. 9-like PNGs there (default: out/multi_limitation)")
    parser.add_argument("--sweep", action="store_true",
                        help="instead: the reactive method over zone widths x stiffnesses (table, or JSON with --json)")


def run(args: argparse.Namespace) -> int:
    if args.sweep:
        rows = sweep()
        if args.json:
            print(json.dumps(rows))
        else:
            print("| zone width [cm] | stiffness [1/s] | scenario | reached | time [s] | min clearance [mm] | max binding |")
            print("|---|---|---|---|---|---|---|")
            for r in rows:
                time_s = f"{r['time_s']:.2f}" if r["time_s"] is not None else "-"
                print(f"| {100 * r['zone_width_m']:.1f} | {r['stiffness_per_s']:.0f} | {r['scenario']} | {r['reached']} | "
                      f"{time_s} | {1000 * r['min_clearance_m']:.1f} | {r['max_binding']} |")
        return 0
    results = [run_scenario(scenario, method) for scenario in SCENARIOS for method in METHODS]
    written = plot(results, args.out or Path("out/multi_limitation"))
    if args.json:
        print(json.dumps([r.as_json() for r in results]))
    else:
        print(f"{'scenario':8} {'method':13} {'reached':7} {'time_s':>7} {'min_clearance_m':>16} {'max_binding':>11}  final binding")
        for r in results:
            time_s = f"{r.time_s:.2f}" if r.time_s is not None else "-"
            print(f"{r.scenario:8} {r.method:13} {str(r.reached):7} {time_s:>7} {r.min_clearance_m:16.5f} "
                  f"{r.max_binding:11d}  {', '.join(r.final_binding) or '-'}")
        print("plots: " + ", ".join(str(p) for p in written))
    return 0
