"""``cobotsafety bench arm --robot NAME``: one full 3D step, beside the human and beside pink.

The step (``ArmTeleop.step`` on the packed path): forward kinematics and Jacobians, every
constraint (joint limits, reach, table, the demo zones for every capsule, joint velocity
limits) with the Jacobians of the capsules' closest points, the projection, the integration
and the safety net's check. The commanded motion presses the hand on the sphere zone so the
projection works. Measured in the same run, interleaved in rounds of ``BLOCK`` calls of each so
that the machine's load falls on all of them alike:

* ``reference_median_us``: the same step on the reference path (``fast=False``);
* ``human_median_us``: the human-aware step (``HumanAwareTeleop``, anticipative) with 5 human
  capsules beside the arm, closing in at 0.3 m/s;
* ``pink_median_us`` (when ``pin-pink`` and ``daqp`` are installed, extra ``[compare]``): pink's
  differential IK on the same model: a FrameTask on the end-effector and a PostureTask, with
  configuration and velocity limits, solved by daqp, then ``pin.integrate``.
"""

from __future__ import annotations

import argparse
import os
import time

from cobotsafety.cli.arguments import positive_int

BLOCK = 10
"""Calls of one step in a row per round: a control loop calls its step again and again, so each
is timed after its own kind (one call each per round would time every call with its caches
just emptied by the 0.8 ms reference step; pink and ours alike)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from cobotsafety.arm.robots import DEFAULT_ROBOT, ROBOTS

    parser.add_argument("--robot", default=DEFAULT_ROBOT, choices=list(ROBOTS))
    parser.add_argument("--json", action="store_true", help='print {"name": "arm_step", "robot": ..., "median_us": ...}')
    parser.add_argument("--runs", type=positive_int, default=2000, help="timed steps (default 2000)")


def _pressing_teleop(robot: str, fast: bool):
    """An ``ArmTeleop`` driven onto its sphere zone; its state there and the pressing command."""
    import numpy as np

    from cobotsafety.arm.teleop import ArmTeleop

    teleop = ArmTeleop(robot, fast=fast)
    state = teleop.state
    target = np.array(teleop.zones[1].center) if hasattr(teleop.zones[1], "center") else state.p_world_ee
    for _ in range(600):
        offset = target - state.p_world_ee
        teleop.step(0.3 * offset / max(np.linalg.norm(offset), 1e-9), 0.002)
    v = 0.3 * (target - state.p_world_ee) / max(np.linalg.norm(target - state.p_world_ee), 1e-9) + np.array([0.0, 0.0, 0.05])
    return teleop, state.q.copy(), teleop.last_command.copy(), v


def _human_teleop(robot: str):
    """A ``HumanAwareTeleop`` with 5 capsules (torso, arms, legs) beside its arm, closing in."""
    import numpy as np

    from cobotsafety.control.human_aware import HumanAwareTeleop
    from cobotsafety.human.body import HumanCapsules

    teleop = HumanAwareTeleop(robot)
    state = teleop.state
    p = state.p_world_ee
    side = np.array([p[0], p[1] + 0.45, 0.0])
    p0 = np.array([side + [0, 0, 0.9], side + [0, -0.2, 1.3], side + [0, 0.2, 1.3], side + [0, -0.1, 0.0],
                   side + [0, 0.1, 0.0]])
    p1 = np.array([side + [0, 0, 1.4], side + [0.1, -0.35, 1.0], side + [0.1, 0.35, 1.0], side + [0, -0.1, 0.9],
                   side + [0, 0.1, 0.9]])
    radius = np.array([0.15, 0.05, 0.05, 0.07, 0.07])
    names = ("torso", "left arm", "right arm", "left leg", "right leg")
    for i in range(3):  # two frames give the velocity estimate a rate
        shift = np.array([0.0, -0.3 * 0.05 * i, 0.0])
        frame = HumanCapsules(p0 + shift, p1 + shift, radius, names, t_s=0.05 * i)
        teleop.set_human(frame)
    return teleop, state.q.copy(), np.array([0.0, 0.2, 0.0])


def _pink_step(state, ee_frame: str):
    """A callable doing one pink step from ``q_start`` toward a target 5 cm away, or None."""
    try:
        import pink
        from pink.limits import ConfigurationLimit, VelocityLimit
        from pink.tasks import FrameTask, PostureTask
    except ImportError:
        return None
    import numpy as np
    import pinocchio as pin

    model = state.model
    configuration = pink.Configuration(model, model.createData(), state.q.copy())
    frame_task = FrameTask(ee_frame, position_cost=1.0, orientation_cost=0.5)
    posture_task = PostureTask(cost=1e-3)
    target = configuration.get_transform_frame_to_world(ee_frame).copy()
    target.translation = target.translation + np.array([0.05, 0.0, 0.0])
    frame_task.set_target(target)
    posture_task.set_target(state.q.copy())
    limits = [ConfigurationLimit(model), VelocityLimit(model)]
    tasks = [frame_task, posture_task]
    q_start = state.q.copy()

    def run():
        configuration.update(q_start)
        velocity = pink.solve_ik(configuration, tasks, 0.002, solver="daqp", limits=limits, safety_break=False)
        return pin.integrate(model, q_start, velocity * 0.002)
    return run


def run(args: argparse.Namespace) -> dict:
    import numpy as np
    import pinocchio as pin

    from cobotsafety.arm.step import ArmParams, all_measures, build_halfspaces, mapping
    from cobotsafety.bench.stopwatch import machine_description

    teleop, q_start, previous, v = _pressing_teleop(args.robot, fast=True)
    reference, _, _, _ = _pressing_teleop(args.robot, fast=False)
    state = teleop.state
    params = ArmParams()
    M, c = mapping(state, params, teleop.R_world_ee_ref)
    hs = build_halfspaces(state, all_measures(state, teleop.constraints, params.activation_m), M, c,
                          v[:len(M[0])], 0.002, params)
    human, q_human, v_human = _human_teleop(args.robot)
    pink_run = _pink_step(state, state.spec.ee_frame) if args.robot != "planar" else None

    def fast_step():
        state.q = q_start
        teleop.last_command = previous
        teleop.step(v, 0.002)

    def reference_step():
        reference.state.q = q_start
        reference.state.update()
        reference.last_command = previous
        reference.step(v, 0.002)

    def human_step():
        human.state.q = q_human
        human.step(v_human, 0.002)

    def pinocchio_only():
        pin.computeJointJacobians(state.model, state.data, q_start)
        pin.updateFramePlacements(state.model, state.data)

    timed = {"median_us": fast_step, "reference_median_us": reference_step, "human_median_us": human_step,
             "pinocchio_kinematics_us": pinocchio_only}
    if pink_run is not None:
        timed["pink_median_us"] = pink_run
    for fn in timed.values():  # warm up (compilation, caches)
        for _ in range(50):
            fn()
    fallbacks_before = sum(teleop.packed.fallbacks.values()) + sum(human.teleop.packed.fallbacks.values())
    samples = {key: np.empty(args.runs) for key in timed}
    clock = time.perf_counter_ns
    load_before = os.getloadavg()[0]
    for first in range(0, args.runs, BLOCK):  # interleaved: a block of calls of each per round
        for key, fn in timed.items():
            for i in range(first, min(first + BLOCK, args.runs)):
                start = clock()
                fn()
                samples[key][i] = clock() - start
    medians = {key: float(np.median(s) / 1e3) for key, s in samples.items()}
    fallbacks = sum(teleop.packed.fallbacks.values()) + sum(human.teleop.packed.fallbacks.values()) - fallbacks_before
    result = {
        "name": "arm_step",
        "robot": args.robot,
        **{key: round(value, 1) for key, value in medians.items()},
        "active_constraints": int(hs.normals.shape[0]),
        "reference_over_fast": round(medians["reference_median_us"] / medians["median_us"], 2),
        "fast_path_fallbacks": int(fallbacks),
        "load_average_1min": round(max(load_before, os.getloadavg()[0]), 2),
        "machine": machine_description(),
    }
    if "pink_median_us" in medians:
        result["fast_over_pink"] = round(medians["median_us"] / medians["pink_median_us"], 3)
        result["human_over_pink"] = round(medians["human_median_us"] / medians["pink_median_us"], 3)
    return result
