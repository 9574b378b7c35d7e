"""``cobotsafety bench distance``: capsule_distance for 15 and 10^5 pairs, beside coal.

coal is called pair by pair from Python in the same run, twice: the bare ``coal.distance``
call on prebuilt shapes and transforms, and the whole conversion from segment end points
(shape + transform per pair) that a caller holding segments pays.
"""

from __future__ import annotations

import argparse

import numpy as np


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> dict:
    import coal

    from cobotsafety import capsule_distance
    from cobotsafety.bench.stopwatch import median_us

    rng = np.random.default_rng(0)

    def batch(n):
        return (rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), np.full(n, 0.1),
                rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), np.full(n, 0.05))

    small, large = batch(15), batch(100_000)
    result = {
        "name": "capsule_distance",
        "median_us": round(median_us(lambda: capsule_distance(*small), runs=5000), 2),
        "pairs_15_us": None,
        "pairs_100000_ms": round(median_us(lambda: capsule_distance(*large), runs=15, warmup=2) / 1e3, 2),
    }
    result["pairs_15_us"] = result["median_us"]

    def shape_and_transform(p0, p1, radius):
        axis = p1 - p0
        length = float(np.linalg.norm(axis))
        z = axis / length
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
        x /= np.linalg.norm(x)
        rotation = np.column_stack([x, np.cross(z, x), z])
        return coal.Capsule(radius, length), coal.Transform3s(rotation, (p0 + p1) / 2)

    a0, a1, ra, b0, b1, rb = small
    request, res = coal.DistanceRequest(), coal.DistanceResult()
    prebuilt = [shape_and_transform(a0[i], a1[i], ra[i]) + shape_and_transform(b0[i], b1[i], rb[i]) for i in range(15)]

    def coal_bare():
        for sa, ta, sb, tb in prebuilt:
            coal.distance(sa, ta, sb, tb, request, res)

    def coal_from_segments():
        for i in range(15):
            sa, ta = shape_and_transform(a0[i], a1[i], ra[i])
            sb, tb = shape_and_transform(b0[i], b1[i], rb[i])
            coal.distance(sa, ta, sb, tb, request, res)

    result["coal_15_pairs_bare_us"] = round(median_us(coal_bare, runs=3000), 2)
    result["coal_15_pairs_from_segments_us"] = round(median_us(coal_from_segments, runs=1000), 2)
    return result
