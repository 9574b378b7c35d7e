"""Random teleoperation runs that count limit crossings: ``python -m cobotsafety.tools.invariant``.

Commands hold a random direction (speeds up to 1 m/s, above the 0.5 m/s cap) for 100 steps at
dt = 2 ms, among the default zones. Counts joint-limit crossings (beyond 1e-9 rad), capsule-zone
penetrations deeper than before (beyond 1e-6 m) and steps with a non-finite state.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from cobotsafety.arm.constraints import JointPositionLimits
from cobotsafety.arm.teleop import ArmTeleop


def run_invariant(robot: str, steps: int, seed: int = 0, dt_s: float = 0.002) -> dict:
    rng = np.random.default_rng(seed)
    teleop = ArmTeleop(robot)
    joints = JointPositionLimits()
    state = teleop.state

    def distances():
        # The zones' exact distances (not ``ZoneConstraint``'s bounded ones): the oracle.
        s = 1  # the base link stands on the table and is not checked, as in the step
        exact = [z.capsule_distances(state.capsule_p0[s:], state.capsule_p1[s:], state.capsule_radius[s:])[0]
                 for z in teleop.zones]
        return joints.distances(state), np.concatenate(exact)

    joint_before, zone_before = distances()
    counts = {"robot": robot, "steps": steps, "joint_crossings": 0, "zone_penetrations": 0,
              "nan_steps": 0, "safety_net_steps": 0, "stopped_steps": 0}
    direction = np.zeros(3)
    for i in range(steps):
        if i % 100 == 0:
            direction = rng.normal(size=3) * rng.uniform(0.05, 1.0)
        report = teleop.step(direction, dt_s, "anticipative")
        if not np.all(np.isfinite(state.q)):
            counts["nan_steps"] += 1
            break
        joint_after, zone_after = distances()
        counts["joint_crossings"] += int(np.sum(joint_after < np.minimum(joint_before, 0) - 1e-9))
        counts["zone_penetrations"] += int(np.sum(zone_after < np.minimum(zone_before, 0) - 1e-6))
        counts["safety_net_steps"] += report.extras["net_scale"] < 1.0
        counts["stopped_steps"] += report.stopped
        joint_before, zone_before = joint_after, zone_after
    packed = getattr(teleop, "packed", None)
    counts["fast_path_fallbacks"] = dict(packed.fallbacks) if packed is not None else None
    return counts


def main(argv: list[str] | None = None) -> int:
    from cobotsafety.arm.robots import ROBOTS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", action="append", choices=list(ROBOTS), help="default: every robot")
    parser.add_argument("--steps", type=int, default=100_000)
    args = parser.parse_args(argv)
    for robot in args.robot or list(ROBOTS):
        print(json.dumps(run_invariant(robot, args.steps)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
