"""``cobotsafety bench NAME [--json]``: median timings, with the machine described.

Each bench module (``cobotsafety/bench/<name>.py``) exposes ``add_arguments(parser)`` and
``run(args) -> dict``; the dict is printed as JSON with ``--json`` (one object, its ``name`` and
``median_us`` keys first) or as ``key: value`` lines otherwise, with one ``machine:`` line
(the bench's own when it has one).
"""

from __future__ import annotations

import argparse
import json

from cobotsafety.cli._dispatch import add_modules

BENCHES: dict[str, tuple[str, str]] = {
    "planar": ("cobotsafety.bench.planar_bench", "one full planar RR step (limitations A-G, projection, integration)"),
    "arm": ("cobotsafety.bench.arm_bench", "one full 3D arm step (FK, Jacobians, constraints, projection, integration)"),
    "distance": ("cobotsafety.bench.distance_bench", "capsule-capsule distance, 15 and 1e5 pairs, against coal"),
    "sensors": ("cobotsafety.bench.sensors_bench", "one laser scan + 5 IMU samples -> 5 human capsules"),
    "app": ("cobotsafety.bench.app_bench", "demo control-loop rate, jitter, latency and start-up time"),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_modules(parser, BENCHES)


def run(args: argparse.Namespace) -> int:
    from cobotsafety.bench.stopwatch import machine_description

    result = args._target_run(args)
    if getattr(args, "json", False):
        print(json.dumps(result))
    else:
        for key, value in result.items():
            print(f"{key}: {value}")
        if "machine" not in result:
            print(f"machine: {machine_description()}")
    return 0
