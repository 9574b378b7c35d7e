"""Paper 1, experiment 3 (Fig. 9): autonomous motion among connected and separated zones.

The end-effector starts at (-0.2, 0.03) m and is driven toward the target (0.22, 0.18) m by a
saturated proportional command ``v = gain (target - p)``; the method under test filters it. The
straight drive meets joint 2's circle B and slides along it toward a wall of zones standing on
B (``planar_scenes.fig9_wall``): in (a) the wall's triangle touches B, a V in which two
limitations bind at once; in (b) a 6 cm gap separates them. A run ends when the target is
reached (within ``tolerance_m``), when the robot has stalled (speed below ``stall_speed_m_s``
for ``stall_time_s``), or at ``timeout_s``.

**Binding**, one definition for every method (``binding_now``): a limitation binds when the
end-effector is within ``BINDING_TOLERANCE_M`` (1 mm) of it, or, for joint limits and the
conditioning safeguard, within ``BINDING_TOLERANCE_RAD`` (1 mrad); a joint's lower and upper
limits count separately. ``max_binding`` is the most limitations binding in one step.

**The safety net.** Every method, sliding, stop and reactive alike, runs behind the same hard
safety net (``planar_step.integrate_with_safety_net``): a step that would cross a limitation
(or go deeper into one already crossed) is scaled down by bisection. So no method can penetrate
a zone here; what differs is how the command gets there. ``net_steps`` counts the steps in
which the net cut the step.

The reactive method depends on its tuning, so ``--sweep`` runs it over ``SweepGrid``: the
linear repulsion zone width, the angular zone width (joint limits: 0.15 rad at joint 2 is
~4.3 cm at the end-effector on circle B, most of (b)'s 6 cm gap), the stiffness and the
damping, in both scenarios. The figure shows, in (b), the setting ``figure_reactive()`` (one
that passes) beside ``stalling_reactive()`` (the defaults, which stall at the triangle as in
the paper), with sliding and stop.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

METHODS = ("anticipative", "reactive", "stop")
SCENARIOS = ("a", "b")
#: A limitation binds within this distance of its boundary [m] (metric limitations) ...
BINDING_TOLERANCE_M = 1e-3
#: ... or this angle [rad] (joint limits, conditioning).
BINDING_TOLERANCE_RAD = 1e-3
FORMATS = ("png", "svg", "pdf")
DPI = 300


@dataclass(frozen=True)
class SweepGrid:
    """The reactive settings ``--sweep`` runs (every combination, both scenarios)."""

    widths_m: tuple[float, ...] = (0.01, 0.02, 0.03, 0.04)
    widths_rad: tuple[float, ...] = (0.05, 0.10, 0.15)
    stiffness_per_s: tuple[float, ...] = (20.0, 60.0, 150.0)
    damping: tuple[float, ...] = (0.1, 0.5, 1.0)

    @property
    def size(self) -> int:
        return len(self.widths_m) * len(self.widths_rad) * len(self.stiffness_per_s) * len(self.damping)


FULL_GRID = SweepGrid()
#: A small grid for tests (``--grid quick``).
QUICK_GRID = SweepGrid((0.02, 0.04), (0.05, 0.15), (60.0,), (0.5,))


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
    """The most limitations binding in one step (``binding_now``)."""
    final_binding: tuple[str, ...] = ()
    """The limitations binding at the end (``binding_now``)."""
    net_steps: int = 0
    """Steps in which the safety net cut the step."""
    reactive: object = None
    """The ``ReactiveParams`` of a reactive run (None otherwise)."""

    def as_json(self) -> dict:
        return {
            "scenario": self.scenario,
            "method": self.method,
            "reached": self.reached,
            "time_s": self.time_s,
            "min_clearance_m": self.min_clearance_m,
            "max_binding": self.max_binding,
            "net_steps": self.net_steps,
        }


def binding_now(limitations, kin) -> tuple[str, ...]:
    """The limitations binding at ``kin`` (sorted names): within ``BINDING_TOLERANCE_M`` (or
    ``_RAD`` for angular ones) of their boundary, on either side."""
    names = set()
    for limitation in limitations:
        for distance, _gx, _gy, name, angular in limitation.measures(kin):
            if distance <= (BINDING_TOLERANCE_RAD if angular else BINDING_TOLERANCE_M):
                names.add(name)
    return tuple(sorted(names))


def figure_reactive():
    """The reactive setting that passes (b), shown in the figure and the JSON: stiffness
    60 /s, 3 cm linear and 0.05 rad angular zones, damping 0.5."""
    from cobotsafety.planar.baselines import ReactiveParams

    return ReactiveParams(stiffness_per_s=60.0, damping=0.5, zone_width_m=0.03, zone_width_rad=0.05)


def stalling_reactive():
    """The reactive defaults (4 cm, 0.15 rad, 60 /s, 0.5): they stall at the triangle in (b)."""
    from cobotsafety.planar.baselines import ReactiveParams

    return ReactiveParams()


def reactive_label(params) -> str:
    return (f"{100 * params.zone_width_m:.0f} cm, {params.zone_width_rad:.2f} rad, {params.stiffness_per_s:.0f} /s, "
            f"damping {params.damping:g}")


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
    max_binding, binding, net_steps = 0, (), 0
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
        net_steps += report.extras.get("net_scale", 1.0) < 1.0
        t += params.dt_s
        kin = robot.kinematics
        binding = binding_now(scene.limitations, kin)
        max_binding = max(max_binding, len(binding))
        for zone in zones:
            clearance[zone.name] = min(clearance[zone.name], zone.distance(kin))
        path.append(report.p_base_ee_m[:2].copy())
        still_s = still_s + params.dt_s if np.linalg.norm(report.v_executed_m_s) < params.stall_speed_m_s else 0.0
        if still_s >= params.stall_time_s:
            break
    used = (reactive or figure_reactive()) if method == "reactive" else None
    return RunResult(scenario, method, reached, round(t, 3) if reached else None,
                     float(min(clearance.values())), clearance, np.array(path), max_binding, binding, net_steps, used)


def sweep(params: DriveParams = DriveParams(), grid: SweepGrid = FULL_GRID) -> list[dict]:
    """The reactive method over every setting of ``grid``, in both scenarios."""
    import itertools

    from cobotsafety.planar.baselines import ReactiveParams

    rows = []
    for width, width_rad, stiffness, damping in itertools.product(grid.widths_m, grid.widths_rad,
                                                                   grid.stiffness_per_s, grid.damping):
        reactive = ReactiveParams(stiffness_per_s=stiffness, damping=damping, zone_width_m=width,
                                  zone_width_rad=width_rad)
        for scenario in SCENARIOS:
            r = run_scenario(scenario, "reactive", params, reactive)
            rows.append({"zone_width_m": width, "zone_width_rad": width_rad, "stiffness_per_s": stiffness,
                         "damping": damping, "scenario": scenario, "reached": r.reached, "time_s": r.time_s,
                         "min_clearance_m": round(r.min_clearance_m, 5), "max_binding": r.max_binding,
                         "net_steps": r.net_steps})
    return rows


def plot(results: list[RunResult], out_dir: Path) -> list[Path]:
    """One figure per scenario (``fig9_a``, ``fig9_b``; each .png at 300 dpi, .svg and .pdf):
    zones, circle B and the end-effector paths of every run given for that scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    from cobotsafety.planar.limitations import PolygonZone, RectangleZone
    from cobotsafety.planar.planar_scenes import FIG9_START_M, FIG9_TARGET_M, fig9_scene, joint_2_circle_radius_m

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    styles = {"anticipative": ("tab:red", "--"), "stop": ("k", ":")}
    reactive_styles = [("tab:blue", "-"), ("tab:cyan", "-.")]
    titles = {"a": "zones joined to circle B: no way through", "b": "a 6 cm gap between circle B and the triangle"}
    for scenario in SCENARIOS:
        fig, ax = plt.subplots(figsize=(5.2, 5.2))
        scene = fig9_scene(scenario)
        for zone in scene.limitations:
            if isinstance(zone, RectangleZone):
                ax.add_patch(Polygon(zone.vertices(), color="0.6"))
            elif isinstance(zone, PolygonZone):
                ax.add_patch(Polygon(zone.vertices_m, color="0.6"))
        ax.add_patch(Circle((0, 0), joint_2_circle_radius_m(scene.arm), fill=False, ls="-.", color="0.4",
                            label="B: joint 2 limit (circle)"))
        k = 0
        for result in results:
            if result.scenario != scenario:
                continue
            if result.method == "reactive":
                color, ls = reactive_styles[k % len(reactive_styles)]
                k += 1
                name = f"reactive ({reactive_label(result.reactive)})"
            else:
                color, ls = styles[result.method]
                name = "sliding (anticipative)" if result.method == "anticipative" else "stop"
            outcome = f"reached in {result.time_s:.2f} s" if result.reached else "stalled"
            ax.plot(result.path_m[:, 0], result.path_m[:, 1], ls=ls, color=color, lw=1.6,
                    label=f"{name}: {outcome}, max {result.max_binding} binding")
        ax.plot(*FIG9_START_M, "ko", label="start")
        ax.plot(*FIG9_TARGET_M, "g*", ms=12, label="target")
        ax.set(xlim=(-0.3, 0.35), ylim=(-0.05, 0.5), aspect="equal", xlabel="x [m]", ylabel="y [m]")
        ax.set_title(f"Fig. 9 ({scenario}): end-effector paths by method, {titles[scenario]}", fontsize=9)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=7, ncol=1, title_fontsize=7,
                  title="Every method runs behind the same hard safety net (a step that would cross a\n"
                        "limitation is scaled down). Binding: within 1 mm (joint limits: 1 mrad) of a limitation.")
        for fmt in FORMATS:
            path = out_dir / f"fig9_{scenario}.{fmt}"
            fig.savefig(path, dpi=DPI, bbox_inches="tight")
            written.append(path)
        plt.close(fig)
    return written


def figure_runs() -> list[RunResult]:
    """The runs of the figure and the JSON: each method in both scenarios (reactive with
    ``figure_reactive()``), and in (b) the stalling reactive setting beside the passing one."""
    results = [run_scenario(scenario, method) for scenario in SCENARIOS for method in METHODS]
    results.append(run_scenario("b", "reactive", reactive=stalling_reactive()))
    return results


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print a JSON list of results")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="write the Fig. 9-like figures there (default: out/multi_limitation)")
    parser.add_argument("--sweep", action="store_true",
                        help="instead: the reactive method over linear and angular zone widths, stiffness and damping "
                             "(table, or JSON with --json)")
    parser.add_argument("--grid", choices=["full", "quick"], default="full",
                        help=f"with --sweep: the full grid ({FULL_GRID.size} settings) or a quick one "
                             f"({QUICK_GRID.size}, for tests)")


SAFETY_NET_NOTE = ("Every method runs behind the same hard safety net: a step that would cross a limitation is "
                   "scaled down (net steps: how often it cut a step).")


def run(args: argparse.Namespace) -> int:
    if args.sweep:
        rows = sweep(grid=QUICK_GRID if args.grid == "quick" else FULL_GRID)
        if args.json:
            print(json.dumps(rows))
        else:
            print(SAFETY_NET_NOTE)
            print("| zone width [cm] | angular zone [rad] | stiffness [1/s] | damping | scenario | reached | time [s] "
                  "| min clearance [mm] | max binding | net steps |")
            print("|---|---|---|---|---|---|---|---|---|---|")
            for r in rows:
                time_s = f"{r['time_s']:.2f}" if r["time_s"] is not None else "-"
                print(f"| {100 * r['zone_width_m']:.1f} | {r['zone_width_rad']:.2f} | {r['stiffness_per_s']:.0f} | "
                      f"{r['damping']:g} | {r['scenario']} | {r['reached']} | {time_s} | "
                      f"{1000 * r['min_clearance_m']:.1f} | {r['max_binding']} | {r['net_steps']} |")
        return 0
    results = figure_runs()
    written = plot(results, args.out or Path("out/multi_limitation"))
    if args.json:
        print(json.dumps([r.as_json() | ({"reactive": reactive_label(r.reactive)} if r.reactive else {})
                          for r in results]))
    else:
        print(SAFETY_NET_NOTE)
        print(f"{'scenario':8} {'method':13} {'reached':7} {'time_s':>7} {'min_clearance_m':>16} {'max_binding':>11} "
              f"{'net_steps':>9}  final binding")
        for r in results:
            time_s = f"{r.time_s:.2f}" if r.time_s is not None else "-"
            name = r.method if r.reactive is None else f"reactive ({reactive_label(r.reactive)})"
            print(f"{r.scenario:8} {name:13} {str(r.reached):7} {time_s:>7} {r.min_clearance_m:16.5f} "
                  f"{r.max_binding:11d} {r.net_steps:9d}  {', '.join(r.final_binding) or '-'}")
        print("figures: " + ", ".join(str(p) for p in written))
    return 0
