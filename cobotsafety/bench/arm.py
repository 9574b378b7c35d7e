"""``cobotsafety bench arm --robot NAME``: one full 3D step, with pinocchio's share.

The step: forward kinematics and Jacobians (pinocchio), every constraint (joint limits, reach,
table, the demo zones for every capsule, joint velocity limits) with the point Jacobians of the
capsules' closest points, the projection, ``pin.integrate`` and the safety net's check. The
commanded motion presses the hand on the sphere zone so the projection works.
"""

from __future__ import annotations

import argparse
import time


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from cobotsafety.arm.robots import DEFAULT_ROBOT, ROBOTS

    parser.add_argument("--robot", default=DEFAULT_ROBOT, choices=list(ROBOTS))
    parser.add_argument("--json", action="store_true", help='print {"name": "arm_step", "robot": ..., "median_us": ...}')
    parser.add_argument("--runs", type=int, default=2000)


def run(args: argparse.Namespace) -> dict:
    import numpy as np
    import pinocchio as pin

    from cobotsafety.arm.step import ArmParams, all_measures, build_halfspaces, mapping
    from cobotsafety.arm.teleop import ArmTeleop
    from cobotsafety.bench.timing import median_us

    teleop = ArmTeleop(args.robot)
    state = teleop.state
    # Drive toward the sphere zone until constraints are active, then time steps from there.
    target = np.array(teleop.zones[1].center) if hasattr(teleop.zones[1], "center") else state.p_world_ee
    for _ in range(600):
        offset = target - state.p_world_ee
        teleop.step(0.3 * offset / max(np.linalg.norm(offset), 1e-9), 0.002)
    q_start = state.q.copy()
    v = 0.3 * (target - state.p_world_ee) / max(np.linalg.norm(target - state.p_world_ee), 1e-9) + np.array([0.0, 0.0, 0.05])
    params = ArmParams()
    M, c = mapping(state, params, teleop.R_world_ee_ref)
    hs = build_halfspaces(state, all_measures(state, teleop.constraints, params.activation_m), M, c, v[:len(M[0])], 0.002, params)

    def full_step():
        state.q = q_start
        state.update()
        teleop.step(v, 0.002)

    def pinocchio_only():
        pin.computeJointJacobians(state.model, state.data, q_start)
        pin.updateFramePlacements(state.model, state.data)

    step_us = median_us(full_step, runs=args.runs)
    pin_us = median_us(pinocchio_only, runs=args.runs)
    return {
        "name": "arm_step",
        "robot": args.robot,
        "median_us": round(step_us, 1),
        "active_constraints": int(hs.normals.shape[0]),
        "pinocchio_kinematics_us": round(pin_us, 1),
        "pinocchio_share": round(2 * pin_us / step_us, 3),
        "note": "share counts the two kinematics updates of a step (before and after integration)",
    }
