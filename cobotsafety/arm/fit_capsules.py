"""Fit one capsule per moving link to its collision geometry; write assets/capsules/<robot>.json.

Run ``python -m cobotsafety.arm.fit_capsules [ROBOT ...]``. For each joint, every collision
vertex attached to it (meshes, or points sampled on primitive cylinders) is expressed in the
joint's frame; the capsule axis is the vertices' principal direction, the radius the largest
distance from that axis, and the segment the shortest one along the axis that keeps every
vertex within the radius (so the capsule covers the link exactly, with no margin beyond the
mesh). A vertex ``v`` at axial coordinate ``s`` and radial distance ``rho`` is covered by every
segment point within ``sqrt(r^2 - rho^2)`` of ``s``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

#: The planar arm has no meshes: 3 cm radius links, like the app draws them.
PLANAR_LINK_RADIUS_M = 0.03


def link_points(collision, model) -> dict[str, np.ndarray]:
    """Joint name -> collision points (k, 3) in that joint's frame [m]."""
    import coal

    points: dict[str, list] = {}
    for geometry in collision.geometryObjects:
        if geometry.parentJoint == 0:
            continue  # the base does not move
        shape = geometry.geometry
        if hasattr(shape, "vertices"):
            local = np.asarray(shape.vertices(), dtype=float) * np.asarray(geometry.meshScale)
        elif isinstance(shape, coal.Cylinder):
            angles = np.linspace(0, 2 * np.pi, 32, endpoint=False)
            ring = np.column_stack([shape.radius * np.cos(angles), shape.radius * np.sin(angles)])
            local = np.vstack([np.column_stack([ring, np.full(32, z)]) for z in (-shape.halfLength, shape.halfLength)])
        elif isinstance(shape, coal.Box):
            h = np.asarray(shape.halfSide)
            local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
        elif isinstance(shape, coal.Sphere):
            local = np.vstack([np.eye(3), -np.eye(3)]) * shape.radius
        else:
            raise TypeError(f"unsupported collision shape {type(shape).__name__} in {geometry.name}")
        placement = geometry.placement
        in_joint = local @ placement.rotation.T + placement.translation
        points.setdefault(model.names[geometry.parentJoint], []).append(in_joint)
    return {joint: np.vstack(p) for joint, p in points.items()}


def fit_capsule(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Smallest-radius-first capsule around ``points`` (k, 3): ``(p0, p1, radius)``."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    axis = vt[0]
    s = (points - centre) @ axis
    radial = np.linalg.norm((points - centre) - s[:, None] * axis, axis=1)
    radius = float(radial.max())
    reach = np.sqrt(np.maximum(radius**2 - radial**2, 0.0))
    # The segment [lo, hi] must come within ``reach`` of every vertex's s.
    lo, hi = float(np.min(s + reach)), float(np.max(s - reach))
    if lo > hi:  # every vertex is within the radius of a single point
        lo = hi = 0.5 * (lo + hi)
    return centre + lo * axis, centre + hi * axis, radius


def fit_robot(name: str) -> dict:
    from cobotsafety.arm.robots import load_robot

    model, collision, _ = load_robot(name)
    capsules = []
    if name == "planar":
        for joint, length in (("joint1", 0.30), ("joint2", 0.30)):
            capsules.append({"name": f"link {joint[-1]}", "joint": joint, "p0": [0.0, 0.0, 0.0],
                             "p1": [length, 0.0, 0.0], "radius_m": PLANAR_LINK_RADIUS_M})
    else:
        for joint, points in link_points(collision, model).items():
            p0, p1, radius = fit_capsule(points)
            capsules.append({"name": joint, "joint": joint, "p0": [round(float(x), 6) for x in p0],
                             "p1": [round(float(x), 6) for x in p1], "radius_m": round(radius + 5e-7, 6)})
    return {"robot": name, "method": "cobotsafety.arm.fit_capsules (collision geometry)", "capsules": capsules}


def main(argv: list[str] | None = None) -> int:
    from cobotsafety.arm.robots import ROBOTS

    names = (argv if argv is not None else sys.argv[1:]) or list(ROBOTS)
    out_dir = Path(__file__).resolve().parents[2] / "assets" / "capsules"
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in names:
        table = fit_robot(name)
        (out_dir / f"{name}.json").write_text(json.dumps(table, indent=1) + "\n")
        print(f"{name}: {len(table['capsules'])} capsules")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
