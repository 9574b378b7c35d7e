"""``cobotsafety bench arm --robot NAME``: one full 3D step, beside the human and beside pink.

The step (``ArmController.step``, from the Python call to its return): forward kinematics and
Jacobians, every limitation (joint limits, reach, table, the demo zones for every capsule, the
joints' speed, acceleration and jerk limits) with the Jacobians of the capsules' closest
points, the joint-space filter, the integration and the safety net's check. The command presses
the hand on the sphere zone, so the filter slides. Measured in the same run, interleaved in
rounds of ``BLOCK`` calls of each so that the machine's load falls on all of them alike:

* ``median_us``: that step;
* ``human_median_us``: the same arm with a 5-capsule human beside it (the human limitation's rows
  active), pressing toward the human;
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


DT_S = 0.001


def _pressing(robot: str):
    """An ``ArmController`` driven onto its sphere zone, and the command that presses it there."""
    import numpy as np

    from cobotsafety.arm.controller import ArmController
    from cobotsafety.arm.limitations import SphereZone

    controller = ArmController(robot)
    target = next(np.array(z.center) for z in controller.zones if isinstance(z, SphereZone))
    for _ in range(1500):
        offset = target - controller.state.p_world_ee
        controller.step(0.2 * offset / max(np.linalg.norm(offset), 1e-9), DT_S)
    v = 0.2 * (target - controller.state.p_world_ee) / max(np.linalg.norm(target - controller.state.p_world_ee), 1e-9)
    return controller, v + np.array([0.0, 0.0, 0.05])


def _beside_a_human(robot: str):
    """An ``ArmController`` with a 5-capsule human 0.45 m beside its hand, pressed toward them."""
    import numpy as np

    from cobotsafety.arm.controller import ArmController
    from cobotsafety.human.body import HumanCapsules

    controller = ArmController(robot, zones=[])
    p = controller.state.p_world_ee
    side = np.array([p[0], p[1] + 0.45, 0.0])
    p0 = np.array([side + [0, 0, 0.9], side + [0, -0.2, 1.3], side + [0, 0.2, 1.3], side + [0, -0.1, 0.0],
                   side + [0, 0.1, 0.0]])
    p1 = np.array([side + [0, 0, 1.4], side + [0.1, -0.35, 1.0], side + [0.1, 0.35, 1.0], side + [0, -0.1, 0.9],
                   side + [0, 0.1, 0.9]])
    radius = np.array([0.15, 0.05, 0.05, 0.07, 0.07])
    names = ("torso", "upper_arm_left", "forearm_left", "upper_arm_right", "forearm_right")
    velocity = np.tile([0.0, -0.1, 0.0], (5, 1))
    controller.set_human(HumanCapsules(p0, p1, radius, names, v0_b_m_s=velocity, v1_b_m_s=velocity))
    v = np.array([0.0, 0.2, 0.0])
    for _ in range(1500):
        controller.set_human(controller.human_frame)  # fresh each step (stale, the watchdog stops the arm)
        controller.step(v, DT_S)
    return controller, v


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

    from cobotsafety.bench.stopwatch import machine_description

    if args.runs < 1:
        raise SystemExit(f"--runs must be >= 1, got {args.runs}")
    controller, v = _pressing(args.robot)
    human, v_human = _beside_a_human(args.robot)
    state = controller.state
    pink_run = _pink_step(state, state.spec.ee_frame)

    def step():
        controller.step(v, DT_S)

    def human_step():
        human.set_human(human.human_frame)  # a fresh frame each step, as the control loop gives it
        human.step(v_human, DT_S)

    data = state.model.createData()
    q = state.q.copy()

    def pinocchio_only():
        pin.computeJointJacobians(state.model, data, q)
        pin.updateFramePlacements(state.model, data)

    timed = {"median_us": step, "human_median_us": human_step, "pinocchio_kinematics_us": pinocchio_only}
    if pink_run is not None:
        timed["pink_median_us"] = pink_run
    for fn in timed.values():  # warm up (compilation, caches)
        for _ in range(50):
            fn()
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
    report = controller.last_report
    result = {
        "name": "arm_step",
        "robot": args.robot,
        **{key: round(value, 1) for key, value in medians.items()},
        "binding": list(report.binding) if report is not None else [],
        "human_binding": list(human.last_report.binding) if human.last_report is not None else [],
        "load_average_1min": round(max(load_before, os.getloadavg()[0]), 2),
        "machine": machine_description(),
    }
    if "pink_median_us" in medians:
        result["fast_over_pink"] = round(medians["median_us"] / medians["pink_median_us"], 3)
        result["human_over_pink"] = round(medians["human_median_us"] / medians["pink_median_us"], 3)
    return result
