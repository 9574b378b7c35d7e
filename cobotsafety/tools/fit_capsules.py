"""Fit one capsule per moving link to its collision geometry; write assets/capsules/<robot>.json.

Run ``python -m cobotsafety.tools.fit_capsules [ROBOT ...]``. For each joint, every collision
vertex attached to it (meshes, or points sampled on primitive cylinders) is expressed in the
joint's frame; the capsule axis is the vertices' principal direction, the radius the largest
distance from that axis, and the segment the shortest one along the axis that keeps every
vertex within the radius (so the capsule covers the link exactly, with no margin beyond the
mesh). A vertex ``v`` at axial coordinate ``s`` and radial distance ``rho`` is covered by every
segment point within ``sqrt(r^2 - rho^2)`` of ``s``.

It also writes ``<robot>-paper.json``, paper 2's three capsules (``PAPER_CAPSULES``) for every
robot with ``arm_joints`` (shoulder, elbow, wrist): the upper-arm capsule centred on the
shoulder-elbow segment and fixed to the elbow joint's parent (where that segment is rigid), the
forearm likewise on elbow-wrist, the tool capsule from the wrist centre along the direction to
the end-effector frame, fixed to the end-effector's joint. Segments are measured at the home pose.
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
    return {"robot": name, "method": "cobotsafety.tools.fit_capsules (collision geometry)", "capsules": capsules}


def paper_table(name: str) -> dict:
    """Paper 2's capsule table for robot ``name`` (first entry: the fitted base capsule)."""
    import pinocchio as pin

    from cobotsafety.arm.robot_capsules import PAPER_CAPSULES, load_capsules
    from cobotsafety.arm.robots import load_robot

    model, _, spec = load_robot(name)
    if len(spec.arm_joints) != 3:
        raise ValueError(f"robot {name!r} names no (shoulder, elbow, wrist) arm_joints")
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.array(spec.home_q, dtype=float))
    shoulder, elbow, wrist = (model.getJointId(j) for j in spec.arm_joints)
    ee = model.frames[model.getFrameId(spec.ee_frame)]
    p_shoulder, p_elbow, p_wrist = (data.oMi[j].translation for j in (shoulder, elbow, wrist))
    p_ee = data.oMf[model.getFrameId(spec.ee_frame)].translation
    axes = [(model.parents[elbow], p_shoulder, p_elbow, True), (model.parents[wrist], p_elbow, p_wrist, True),
            (ee.parentJoint, p_wrist, p_ee, False)]
    base = load_capsules(name)[0]
    capsules = [{"name": f"{base.name} (base, not checked)", "joint": base.joint, "p0": list(base.p0_joint),
                 "p1": list(base.p1_joint), "radius_m": base.radius_m}]
    for (label, length, radius), (joint, a, b, centred) in zip(PAPER_CAPSULES, axes):
        direction = (b - a) / np.linalg.norm(b - a)
        start = 0.5 * (a + b) - 0.5 * length * direction if centred else a
        ends = [data.oMi[joint].actInv(p) for p in (start, start + length * direction)]
        capsules.append({"name": label, "joint": model.names[joint], "p0": [round(float(x), 6) for x in ends[0]],
                         "p1": [round(float(x), 6) for x in ends[1]], "radius_m": radius})
    return {"robot": name, "method": "cobotsafety.tools.fit_capsules (paper 2, section 5: 3 capsules)",
            "capsules": capsules}


def main(argv: list[str] | None = None) -> int:
    from cobotsafety.arm.robots import ROBOTS

    names = (argv if argv is not None else sys.argv[1:]) or list(ROBOTS)
    out_dir = Path(__file__).resolve().parents[1] / "assets" / "capsules"
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in names:
        table = fit_robot(name)
        (out_dir / f"{name}.json").write_text(json.dumps(table, indent=1) + "\n")
        print(f"{name}: {len(table['capsules'])} capsules")
        if ROBOTS[name].arm_joints:
            (out_dir / f"{name}-paper.json").write_text(json.dumps(paper_table(name), indent=1) + "\n")
            print(f"{name}: paper 2's capsules")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
