"""``cobotsafety bench planar``: one full planar step (limitations A-G, projection, integration).

The demo scene configures every limitation of section II; the command alternates between a
free motion and one that presses on a limitation, so the projection works. The step is timed
interleaved with the reference safety net (every limitation's full measures re-evaluated,
``step(..., reachable_only=False)``), so ``ratio`` compares the two in the same run.
``--invariant N`` also runs N random steps (dt up to 10 ms) and counts crossings beyond 1e-9.
"""

from __future__ import annotations

import argparse

import numpy as np

from cobotsafety.cli.arguments import non_negative_int, positive_int


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true",
                        help='print {"name": "planar_step", "median_us": ..., "reference_net_median_us": ...}')
    parser.add_argument("--runs", type=positive_int, default=20_000, help="timed steps (default 20000)")
    parser.add_argument("--invariant", type=non_negative_int, default=0, metavar="N",
                        help="also run N random steps and count limitation crossings")


def run(args: argparse.Namespace) -> dict:
    import os
    import time

    from cobotsafety.bench.stopwatch import machine_description
    from cobotsafety.planar.rr_arm import Kinematics
    from cobotsafety.planar.planar_scenes import demo_scene
    from cobotsafety.planar.planar_step import PlanarState, measures, step

    scene = demo_scene()
    t1, t2 = scene.arm.inverse_kinematics(-0.2, 0.03)
    start = PlanarState(t1, t2)
    # Pressing on the base / joint-2 circle while moving: the projection is active.
    commands = [(0.05, 0.02), (0.2, -0.1)]
    state = {"i": 0}

    def timed(reachable_only: bool) -> float:
        state["i"] += 1
        command = commands[state["i"] & 1]
        begin = time.perf_counter_ns()
        step(start, command, 0.002, scene, reachable_only=reachable_only)
        return (time.perf_counter_ns() - begin) / 1e3

    for _ in range(200):  # warm-up
        timed(True), timed(False)
    fast, reference = np.empty(args.runs), np.empty(args.runs)
    for i in range(args.runs):  # interleaved: both see the same machine load
        fast[i], reference[i] = timed(True), timed(False)
    result = {"name": "planar_step", "median_us": round(float(np.median(fast)), 2),
              "reference_net_median_us": round(float(np.median(reference)), 2),
              "ratio": round(float(np.median(fast) / np.median(reference)), 3),
              "limitations": len(scene.limitations), "load_1min": round(os.getloadavg()[0], 2),
              "machine": machine_description()}
    if args.invariant:
        rng = np.random.default_rng(0)
        s, crossings, worst, net = start, 0, 0.0, 0
        prev = [m[0] for m in measures(scene, Kinematics(scene.arm, t1, t2))]
        direction = np.zeros(2)
        for i in range(args.invariant):
            if i % 50 == 0:
                direction = rng.normal(size=2) * rng.choice([0.05, 0.3, 2.0])
            s, info = step(s, direction, rng.uniform(1e-4, 0.01), scene)
            net += info.net_scale < 1.0
            now = [m[0] for m in measures(scene, Kinematics(scene.arm, s.theta_1, s.theta_2))]
            for d0, d1 in zip(prev, now):
                excess = d1 - min(d0, 0.0)
                worst = min(worst, excess)
                crossings += excess < -1e-9
            prev = now
        result.update({"invariant_steps": args.invariant, "crossings": crossings,
                       "worst_crossing": worst, "safety_net_steps": net})
    return result
